// How wrong an estimated part pose is where it matters: at the weld seams. Poses that put every seam in the
// same place weld the same part (a square plate turned 90 deg, a circular seam turned about its axis), so the
// seam error is the symmetric Hausdorff distance between the seams placed by the estimate and the true seams,
// and the rotation error is taken modulo the part's rotational symmetry about its z axis.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "core/part_spec.hpp"
#include "perception/mesh_io.hpp"

namespace weldtwin {

struct PoseError {
  double seam_max_m = 0.0;    ///< worst seam point: max over both seam sets of the distance to the other
  double seam_mean_m = 0.0;   ///< mean over the estimate's seam points of the distance to the true seams
  double rotation_rad = 0.0;  ///< angle of R_true^-1 R_est, least over the part's z symmetries (for seams
                              ///< that are full circles about one vertical axis: the tilt of that axis only)
  double origin_m = 0.0;      ///< distance between the part origins (after the best symmetry)
};

/// Rotational symmetry order of `mesh` about its z axis through the origin: the largest N in 1..8 such that
/// turning it by 360/N deg maps its vertices onto its surface within `tolerance_m`.
int z_symmetry_order(const Mesh& mesh, double tolerance_m = 2e-4);

/// Errors of `estimate` against `truth` (both T_base_part). `symmetry_order` as z_symmetry_order().
PoseError pose_error(const PartSpec& part, const Iso3& estimate, const Iso3& truth, int symmetry_order = 1);

/// How far apart two sets of seam points are, both ways (the symmetric Hausdorff distance of the two sets)
/// [m]. For a part that is not its CAD: the CAD's seams where a pose puts them against the part's own seams
/// where they really are, each densely sampled (their spacing adds up to half of it).
double seam_distance_m(const std::vector<Vec3>& a, const std::vector<Vec3>& b);

/// The truth of a sample scan (`truth.json` beside `scan.pcd`: T_base_part, and the seams as line segments
/// in the part frame under `seams_part`) as a pose and a part holding those seams. Throws InputError.
struct SampleTruth {
  Iso3 T_base_part = Iso3::Identity();
  PartSpec part;
};
SampleTruth read_sample_truth(const std::string& truth_json);

}  // namespace weldtwin
