// The LiDAR mount file (docs/design.md): the correction `weldtwin calibrate` measures for the LiDAR's mount
// on its link, which `weldtwin run --lidar-mount` applies when it assembles a sweep.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// What a mount file says: the link the LiDAR hangs on, and the correction right-multiplied onto its URDF
/// origin.
struct MountCorrection {
  std::string lidar_link;
  Iso3 correction = Iso3::Identity();
};

/// A mount offset from translation [mm] and roll, pitch, yaw [deg] (R = Rz(yaw) Ry(pitch) Rx(roll)); either
/// may be empty (zero), else it holds three numbers.
Iso3 mount_offset(const std::vector<double>& xyz_mm, const std::vector<double>& rpy_deg);

/// Roll, pitch, yaw [deg] of R = Rz(yaw) Ry(pitch) Rx(roll), as URDF's rpy, on the branch near zero.
Vec3 rpy_deg(const Mat3& R);

/// The mount JSON's own fields (lidar_link, correction {xyz_m, rpy_deg}, a note saying how it applies);
/// calibrate adds its figures beside them.
nlohmann::json mount_correction_json(const MountCorrection& mount);

/// The correction of a mount file; InputError naming the file when it is not one.
MountCorrection read_mount_file(const std::string& path);

}  // namespace weldtwin
