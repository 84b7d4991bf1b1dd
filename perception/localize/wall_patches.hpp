// Whether the scan's walls stand where the model's do, patch by patch. The residuals of the rays that met the
// model's walls (each on the face its ray meets, so no point thrown past a thin wall's middle is taken for
// the far face) are gathered per patch (a cell of the part frame and the way its wall faces); a patch is off
// when its mean residual lies further from zero than its own points' spread explains (a number of standard
// errors) and by more than a floor. The share of the wall points in patches that are off tells a different
// shape: another part's mesh lies off over a good part of its walls, a right pose within a few per cent,
// however noisy the scan (each patch is judged by its own spread, not by the table's noise).
#pragma once

#include <cstddef>
#include <unordered_map>
#include <vector>

#include "core/geometry.hpp"
#include "perception/localize/pose_uncertainty.hpp"

namespace weldtwin {

struct WallPatchSetting {
  double patch_m = 0.015;      ///< the patches' edge in the part frame [m]
  int facings = 8;             ///< walls facing apart by more than a turn over this many are apart
  int min_points = 3;          ///< patches with fewer points are not judged
  double off_sigmas = 4.0;     ///< a patch is off when its mean residual is this many standard errors ...
  double min_offset_m = 5e-4;  ///< ... and at least this far from the model's wall [m]
};

/// What the patches say: the share of the wall points in patches that are off, and the patch off with the
/// most points (its centre on the model, part frame, and its mean residual).
struct WallPatchFigure {
  double off_share = 0.0;
  Vec3 worst_at = Vec3::Zero();  ///< [m]
  double worst_offset_m = 0.0;   ///< positive: the scan outside the model's wall [m]
};

class WallPatches {
 public:
  explicit WallPatches(const WallPatchSetting& setting = {}) : s_(setting) {}
  /// A scan point whose nearest model sample on a wall is at `at`, facing `normal`, with residual `r` along
  /// it [m].
  void add(const Vec3& at, const Vec3& normal, double r);
  WallPatchFigure figure() const;

 private:
  struct Patch {
    size_t n = 0;
    double sum = 0.0, sum2 = 0.0;
    Vec3 at = Vec3::Zero();
  };
  WallPatchSetting s_;
  std::unordered_map<long long, Patch> patches_;
};

/// The walls of a fit by rays (planar_icp.hpp): its residuals on the faces the rays met (`fitted`), and
/// those beyond its trim clipped there (`beyond_trim`: where the scan lies far off the model counts as far
/// off as the trim, not as nothing).
WallPatchFigure walls_off_model(const std::vector<ResidualTerm>& fitted,
                                const std::vector<ResidualTerm>& beyond_trim,
                                const WallPatchSetting& setting = {});

}  // namespace weldtwin
