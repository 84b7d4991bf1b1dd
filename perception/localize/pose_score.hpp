// Stage 5 of the localizer: how well a pose explains the scan. Scan points in the model's region it
// explains (inliers, RMSE), the walls' residual against the noise, the share of the model's visible surface
// the scan confirms (coverage), and free space: the table seen where the part would rest.
#pragma once

#include <cstdint>
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
  /// With rays: at most this share of the rays crossing the model may go through it; a pose above it is no
  /// candidate (right poses: 0-3 % on full sweeps, up to 9 % on one pass, from rays that graze its edges;
  /// another part: 19-27 %)
  double max_see_through_share = 0.15;
  double footprint_erosion_sigmas = 2.0;   ///< the footprint is eroded by this many noise sigmas ...
  double min_footprint_erosion_m = 0.003;  ///< ... and at least this [m]
};

struct Score {
  int inliers = 0, region = 0;
  double wall_residual = 0.0;  ///< median |residual| of the points near walls, in noise sigmas
  double rmse = 0.0, coverage = 0.0, free_space = 0.0;
  double max_free = 0.02;
  /// With rays (else 0): the share of the rays crossing the model that went through it, and the coverage of
  /// the samples the rays reached (see see_through.hpp; -1 when no sample was reached).
  double see_through = 0.0, reached_coverage = -1.0;
  int ray_count = 0, through_count = 0;  ///< with rays: those crossing the model's box, and through it
  double max_see_through = 0.15;
  /// With rays: the region of the model most rays went through (SeeThrough::region_*), and whether they say
  /// the part is not there (the verdict's, not the candidates' test: which pose is best stays the score's)
  int region_through = 0, region_rays = 0;
  Vec3 region_at = Vec3::Zero();
  bool region_seen_through = false;
  /// Whether the scan leaves room for the part here: the table not seen under it, no ray through it.
  bool allowed() const { return free_space <= max_free && see_through <= max_see_through; }
  /// Evidence for the pose: scan points it explains times the share of its visible surface the scan
  /// confirms, discounted by the table seen where it would stand.
  double support() const { return inliers * coverage * std::max(0.0, 1.0 - free_space / max_free); }
};

/// The score of pose P (table frame -> part frame); `footprint` is the model's, eroded by the noise.
Score score_pose(const ScenePoints& scene, const Grid2& footprint, PartModel& model, const Iso3& P,
                 const PoseScoreSetting& setting = {});

/// The share of the model's visible samples (facing up or sideways, above the height cut) with a scan point
/// near at pose P; with `among` (one flag per model sample), of those flagged only (0 when none is).
double coverage(const ScenePoints& scene, const PartModel& model, const Iso3& P,
                const std::vector<uint8_t>& among = {}, const PoseScoreSetting& setting = {});

/// Whether a is the better candidate: allowed by the free space and the rays first, then more support.
bool better_score(const Score& a, const Score& b);

}  // namespace weldtwin
