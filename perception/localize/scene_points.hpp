// Stage 2 of the localizer: the scan's points in the table's frame, sorted by what they can tell. Points
// standing on the table (voxelised: the objects, which the search and the score read), their neighbourhood
// centroids (which decide a point's match in ICP without viewpoints), the points near the table averaged
// per cell (where the table is seen, and the height step across a low part's outline), and, when every
// point's viewpoint is known, the points whose rays the fine refinement casts.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "perception/localize/grid2.hpp"
#include "perception/localize/point_tree.hpp"
#include "perception/localize/zeroed_slots.hpp"

namespace weldtwin {

struct ScenePointsSetting {
  double base_keepout_m = 0.12;    ///< points this close to the base axis are the robot's base [m]
  double min_height_m = 0.005;     ///< points at least this far above the table belong to objects [m]
  double height_cut_sigmas = 3.0;  ///< points this close to the table (noise sigmas) are not used by ICP
  double above_part_m = 0.05;      ///< points this far above the part's top are not it [m]
  double voxel_m = 0.002;          ///< voxel edge for the object points [m]
  int smoothing_neighbours = 8;    ///< neighbours whose centroid decides a point's match
  double smoothing_radius_sigmas = 2.0;  ///< ... within this many noise sigmas (and at least 4 mm)
  double low_cell_m = 0.002;             ///< cell of the grid of points near the table [m]
  double min_viewpoint_height_m = 0.05;  ///< a LiDAR scanning the table looks from at least this high [m]
  double viewpoints_above_share = 0.9;   ///< ... for this share of the points, or the viewpoints are unused
};

/// Thresholds that follow from the range noise measured on the table.
struct NoiseLimits {
  double noise_m = 0.001;        ///< range noise sigma [m]
  double trim_m = 0.0025;        ///< ICP residuals beyond this are not used [m]
  double inlier_m = 0.003;       ///< a residual within this explains a point [m]
  double edge_margin_m = 0.002;  ///< model samples this close to a feature edge are not matched [m]
  double height_cut_m = 0.005;   ///< points this close to the table are not used by ICP [m]
};

/// A scan point, and the centroid of its neighbourhood: which model face and sample a point is matched with
/// is decided by the centroid, whose noise is a fraction of the point's own, so that the choice does not
/// depend on where the point's noise threw it (near an edge, a ray's noise moves a point both off the face
/// and along it; a choice by the point itself would keep one sign of the noise and drop the other). Where the
/// ray is known, the ray itself decides, and no noise enters the choice at all.
struct ScanPoint {
  Vec3 raw, smooth;
  Vec3 ray = Vec3::Zero();     ///< unit direction from the sensor to the point (table frame), when known
  Vec3 origin = Vec3::Zero();  ///< the sensor's position (table frame), when the ray is known
  double range = 0.0;          ///< 0: the ray is not known
};

struct ScenePoints {
  bool ok = false;
  std::string reason;  ///< why not: nothing stands on the table
  NoiseLimits limits;
  Iso3 T_base_table = Iso3::Identity(), T_table_base = Iso3::Identity();
  std::vector<Vec3> objects;          ///< voxel centroids of the points standing on the table (table frame)
  PointTree tree;                     ///< over `objects`
  std::vector<ScanPoint> icp_points;  ///< objects high enough to be told from the table, with centroids
  // Points near the table (table frame), averaged per cell: where the outline of a part too low for its walls
  // to be told from the table is read from the change of height across it, and where the table is seen.
  Grid2 low;                   ///< its cells only (`on` and `value` unused): the sums and counts below
  ZeroedSlots<float> low_sum;  ///< per cell of `low`; null when no scene was sorted
  ZeroedSlots<uint16_t> low_count;
  double outline_max_top = 0.0;  ///< outline samples of parts at most this high are read this way [m]
  std::vector<uint32_t>
      ray_points;  ///< scan indices of every point near or above the table, when the rays are known
};

/// Sorts `scan_base` within `reach_radius_m` of the base axis by the table `plane` (n.x + d = 0) and the
/// part's height. `viewpoints_base` (one per
/// point, or none) are used only if they look like a LiDAR above the table.
ScenePoints scene_points(const std::vector<Vec3>& scan_base, const std::vector<Vec3>& viewpoints_base,
                         const Eigen::Vector4d& plane, const NoiseLimits& limits, double part_height_m,
                         double reach_radius_m, const ScenePointsSetting& setting = {});

}  // namespace weldtwin
