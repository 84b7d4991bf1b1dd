// Stage 1 of the localizer: the table the part rests on. Cascaded RANSAC for near-horizontal planes; of
// those spread over enough area (box tops are not), the highest (the floor is lower), refined by least
// squares away from everything standing on it. The spread of its points about it is the range noise sigma
// that sets every later threshold.
#pragma once

#include <limits>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

struct TablePlaneSetting {
  double reach_radius_m = 1.2;  ///< the table is sought within this distance of the base axis [m]
  double threshold_m = 0.006;   ///< RANSAC inlier distance for the table plane [m]
  double max_tilt_deg = 15.0;   ///< the table plane's normal is within this angle of +z [deg]
  int sample_points = 10000;    ///< points the RANSAC looks at, about (drawn at random; all if fewer)
  int ransac_iterations = 300;  ///< RANSAC iterations per plane
  int max_planes = 4;           ///< planes peeled off one after another
  double min_area_m2 = 0.15;    ///< a plane seen over less area is a box top, not the table [m^2]
  double min_noise_m = 0.0005;  ///< floor of the estimated range noise [m]
  int refit_rounds = 12;        ///< least-squares rounds at most, the band narrowed to the noise learnt ...
  /// ... until the plane (within the reach) and the noise move less than this: a few of the plane's own
  /// standard errors (1 mm of noise over 40 k points puts its height within 5 um) [m]
  double settled_m = 1e-5;
  double band_sigmas = 3.5;          ///< the refit's band half-width, in noise sigmas
  double min_band_m = 0.002;         ///< the band's least half-width [m]
  double raised_cell_m = 0.01;       ///< cells where something stands on the table are left out [m]
  double max_raised_height_m = 0.5;  ///< points this far above the plane are not the feet of anything [m]
  /// Where the cell has its table top, when it is known: the plane z = this in the base frame (NaN: not
  /// known, as for a cloud from elsewhere). A scan whose table lies elsewhere was assembled through a LiDAR
  /// mount that is off (TableDiscrepancy) [m]
  double cell_top_z_m = std::numeric_limits<double>::quiet_NaN();
};

struct TablePlane {
  bool found = false;
  Eigen::Vector4d plane = Eigen::Vector4d::Zero();  ///< n.x + d = 0, n up, base frame
  double noise_m = 0.0;                             ///< robust sigma of the points about it [m]
};

/// The table in `scan_base` (see the file comment); `found` false if there is none.
TablePlane find_table_plane(const std::vector<Vec3>& scan_base, const TablePlaneSetting& setting = {});

/// How far the table a scan shows (`plane`) lies from the cell's (the plane z = `top_z_m`), where it matters:
/// the localizer stands the part on the table it sees, so a point of the part rises or sinks by the two
/// planes' height difference under it, and one h above the table leans sideways by h times their angle.
struct TableDiscrepancy {
  double shift_m = 0.0;   ///< the most any of the points moves by that alone (height + lean) [m]
  double height_m = 0.0;  ///< the scan's table above the cell's under the points' middle [m]
  double tilt_rad = 0.0;  ///< the angle between the two planes [rad]
};
/// ... for `points_base` (the part's seams where they were found, base frame).
TableDiscrepancy table_discrepancy(const Eigen::Vector4d& plane, double top_z_m,
                                   const std::vector<Vec3>& points_base);

/// A frame on the plane: z along its normal, origin the plane point nearest the base origin (T_base_table).
Iso3 table_frame(const Eigen::Vector4d& plane);

}  // namespace weldtwin
