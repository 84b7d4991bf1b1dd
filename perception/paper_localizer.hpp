// The published pipeline, kept as the baseline that benchmarks compare against in the same run: PassThrough
// crop, voxel grid, statistical outlier removal, cascaded RANSAC planes (the table, then big planes standing
// above the part's height: clamp tops), Euclidean clustering, and PCL's point-to-point ICP from a centroid
// guess (the model's centroid on the cluster's, yaw 0) against samples of the whole mesh. It has no verdict
// of its own: it always answers, with PCL's fitness score.
#pragma once

#include <vector>

#include "perception/localizer.hpp"

namespace weldtwin {

struct PaperSetting {
  double reach_radius_m = 1.2;  ///< PassThrough in x and y around the base axis
  double z_min_m = -0.05, z_max_m = 0.5;
  double voxel_m = 0.003;
  int outlier_neighbours = 30;
  double outlier_stddev = 1.0;
  double plane_threshold_m = 0.004;
  double cluster_tolerance_m = 0.008;
  int icp_iterations = 50;
  double icp_max_distance_m = 0.05;
  /// ICP's correspondences without searching again for a source point whose nearest target point cannot have
  /// changed since it was last searched: the same matches as PCL's search for each (false: PCL's own
  /// correspondence estimation, for comparison).
  bool icp_reuse_neighbours = true;
};

/// The baseline. `found` is true whenever a cluster was registered; `rmse_m` is the root of PCL's fitness.
PoseEstimate localize_paper(const std::vector<Vec3>& scan_base, const Mesh& model,
                            const PaperSetting& setting = {});

}  // namespace weldtwin
