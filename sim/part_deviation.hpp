// The part as it really is, not as its CAD: each extent a little off, tack welds standing proud of the seams,
// a slight bend along its length. The twin sweeps the deviated part while the localizer seeks the CAD, as a
// real cell does (the survey's part-deviation condition).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh_file.hpp"

namespace weldtwin {

struct PartDeviationSetting {
  double dimension_m = 0.0;    ///< each extent (x, y, z) off by a draw uniform in +-this [m]
  int tack_welds = 0;          ///< tack welds at this many points drawn along the seams
  double tack_edge_m = 0.006;  ///< ... each a cube of this edge centred on the seam (half of it proud) [m]
  double bend_deg = 0.0;       ///< bent along its longest horizontal extent by a draw uniform in +-this [deg]
  bool any() const { return dimension_m > 0.0 || tack_welds > 0 || bend_deg > 0.0; }
};

struct DeviatedPart {
  Mesh mesh;
  Vec3 scale =
      Vec3::Ones();         ///< of each extent (about the box's centre; the lowest face stays at its height)
  std::vector<Vec3> tacks;  ///< where the tack welds are (part frame, before scaling and bending)
  double bend_rad = 0.0;    ///< the bend's angle over the longest horizontal extent
  int bend_axis = 0;        ///< 0: along x (the bend moves points along y), 1: along y (moves them along x)
  Vec3 centre = Vec3::Zero();  ///< the CAD's box centre: extents scale about it ...
  double floor_z = 0.0;        ///< ... but for z, which scales from the lowest face (it stays on the table)
  double curvature = 0.0;      ///< the bend's angle per metre along bend_axis [rad/m]
  /// Where a point of the CAD (part frame) lies on the deviated part: its mesh's vertices, and its seams as
  /// they really are.
  Vec3 apply(const Vec3& cad_point) const;
  std::string describe() const;
};

/// `cad` (part frame) deviated by a seeded draw of `setting`; `seam_points` (part frame) are where the tack
/// welds may go.
DeviatedPart deviate_part(const Mesh& cad, const std::vector<Vec3>& seam_points,
                          const PartDeviationSetting& setting, uint64_t seed);

}  // namespace weldtwin
