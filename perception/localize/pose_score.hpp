// Stage 5 of the localizer: how well a pose explains the scan. Scan points in the model's region it
// explains (inliers, RMSE), the walls' residual against the noise, the share of the model's visible surface
// the scan confirms (coverage), and free space: the table seen where the part would rest.
#pragma once

#include <vector>

#include "perception/localize/grid2.hpp"
#include "perception/localize/part_model.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct PoseScoreSetting {
  double box_margin_m = 0.005;  ///< the model's region: its box grown by this [m]
  double above_top_m = 0.05;   ///< ... and this far above its top: a part taller than the model is not it [m]
  double wall_normal_z = 0.5;  ///< samples with |n.z| below this are walls
  double wall_reach_m = 0.01;  ///< scan points within this of a wall sample count for its residual [m]
  double inlier_sigmas = 2.5;  ///< a residual within this many noise sigmas explains a point ...
  double min_inlier_m = 0.0015;         ///< ... and at least within this [m]
  int coverage_stride = 3;              ///< every this many model samples are looked at for coverage
  double coverage_min_normal_z = -0.2;  ///< samples facing further down are not expected to be seen
  double coverage_sigmas = 2.0;         ///< a sample is seen with a scan point within this many sigmas ...
  double min_coverage_reach_m = 0.004;  ///< ... and at least within this [m]
  double free_space_sigmas = 3.0;       ///< the table is seen through the part this far below its lowest top
  double max_free_space = 0.02;         ///< share of the footprint; a pose above it is no candidate
  double footprint_erosion_sigmas = 2.0;   ///< the footprint is eroded by this many noise sigmas ...
  double min_footprint_erosion_m = 0.003;  ///< ... and at least this [m]
};

struct Score {
  int inliers = 0, region = 0;
  double wall_residual = 0.0;  ///< median |residual| of the points near walls, in noise sigmas
  double rmse = 0.0, coverage = 0.0, free_space = 0.0;
  double max_free = 0.02;
  /// Evidence for the pose: scan points it explains times the share of its visible surface the scan
  /// confirms, discounted by the table seen where it would stand.
  double support() const { return inliers * coverage * std::max(0.0, 1.0 - free_space / max_free); }
};

/// The score of pose P (table frame -> part frame); `footprint` is the model's, eroded by the noise.
Score score_pose(const ScenePoints& scene, const Grid2& footprint, PartModel& model, const Iso3& P,
                 const PoseScoreSetting& setting = {});

/// Whether a is the better candidate: allowed by the free space first, then more support.
bool better_score(const Score& a, const Score& b, const PoseScoreSetting& setting = {});

}  // namespace weldtwin
