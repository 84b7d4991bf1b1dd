// What a part spec may leave out, taken from its mesh: the height, the outline on the table and the places a
// clamp can press. The part frame's z = 0 is where the part rests on the table.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "core/mesh_file.hpp"
#include "core/part_spec.hpp"

namespace weldtwin {

/// The mesh's axis-aligned box in the part frame [m]: lo.z() is its base, hi.z() its height above the table.
struct MeshBox {
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
};
MeshBox mesh_box(const Mesh& mesh);

/// The mesh seen from above: the convex outline of its vertices on the table plane, counter-clockwise,
/// without collinear points. For a part that is not convex seen from above it holds the part with some table
/// around it, which is what the layout checks need (nothing may stand there).
std::vector<Eigen::Vector2d> convex_outline(const Mesh& mesh);

/// The highest surface of the mesh above (x, y) and its unit normal; nullopt where the mesh is not above it.
struct SurfaceAbove {
  double z_m = 0.0;
  Vec3 normal = Vec3::UnitZ();
};
std::optional<SurfaceAbove> surface_above(const Mesh& mesh, const Eigen::Vector2d& xy);

struct ClampSiteSettings {
  double edge_clearance_m = 0.012;  ///< the pad's centre this far inside the outline's edges [m]
  double seam_clearance_m =
      0.030;                   ///< the pad's centre at least this far from every seam, seen from above [m]
  double flatness_m = 0.0005;  ///< the pad's whole disc on one face: heights within this [m]
  double min_face_normal_z = 0.96;   ///< a face the pad presses on is level within about 16 deg
  double min_grip_height_m = 0.001;  ///< a grip on the part, not on the table [m]
};

/// Where a clamp can press on a part whose spec names none: at each convex corner of `outline` (inset along
/// the corner's bisector) and at the middle of each edge long enough for the pad (inset along its normal),
/// wherever the pad's disc rests on one level face of the part, away from the seams. `outward` points from
/// the part towards the clamp body. Deterministic; sites closer than a pad's diameter to an earlier one are
/// left out.
std::vector<ClampSite> outline_clamp_sites(const Mesh& mesh, const std::vector<Eigen::Vector2d>& outline,
                                           const std::vector<Seam>& seams,
                                           const ClampSiteSettings& settings = {});

}  // namespace weldtwin
