// The LiDAR's mount on its link, found from one sweep of the bare table with a known box on it: with the
// right mount, every table point lies at z = 0 of the base frame and every box point on the box's faces. The
// box's pose on the table (x, y, yaw) is found along with the mount (6 parameters), by Gauss-Newton on
// point-to-plane residuals, re-associating points to the table and the box faces and trimming outliers at
// every round. A mount error shows up differently in every attitude of the sweep, which is what makes all six
// parameters observable.
#pragma once

#include <string>

#include "core/geometry.hpp"
#include "core/robot_model.hpp"
#include "core/scan_log.hpp"
#include "perception/mesh_io.hpp"

namespace weldtwin {

struct MountCalibrationSetting {
  Vec3 box_size_m = Vec3(0.25, 0.15, 0.10);  ///< the known box (x, y, z extents), resting on the table
  int max_points = 120000;                   ///< points used (evenly thinned)
  int rounds = 12;                           ///< association rounds (each with a few Gauss-Newton steps)
  double near_m = 0.02;                      ///< points this close to the table plane or a box face are used
  double keep_out_radius_m = 0.25;           ///< points this close to the robot's base axis are not used

  /// The defaults, for the box whose mesh this is (its extents).
  static MountCalibrationSetting for_box(const Mesh& box);
};

struct MountCalibration {
  Iso3 delta = Iso3::Identity();       ///< the mount correction: lidar link = URDF mount * delta
  Iso3 T_base_box = Iso3::Identity();  ///< the box found, bottom centre
  double rms_m = 0.0;                  ///< of the residuals used
  int table_points = 0, box_points = 0;
  bool converged = false;
};

/// Finds the mount of the log's lidar frame on its parent link. Throws InputError (naming `source`) when the
/// sweep does not show the table and the box.
MountCalibration calibrate_mount(const ScanLog& log, const RobotModel& robot,
                                 const MountCalibrationSetting& setting = {},
                                 const std::string& source = "scan");

}  // namespace weldtwin
