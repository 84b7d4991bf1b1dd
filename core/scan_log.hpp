// ScanLog: what a sweep produces, in the twin or in a real cell — LiDAR turns of timed samples and the arm's
// timed joint states. One file format (docs/scanlog.md): a text magic line, a one-line JSON header, then
// little-endian binary records.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace weldtwin {

/// One LiDAR measurement. The angle is counter-clockwise about the lidar frame's +z, from its +x.
struct LidarSample {
  double t_s = 0.0;        ///< time since the start of the sweep [s]
  float angle_rad = 0.0f;  ///< [rad], in [0, 2 pi)
  float range_m = 0.0f;    ///< [m]; 0 means no return
  uint8_t quality = 0;     ///< signal quality 0..255 (0: no return), as the RPLIDAR reports it
};

struct LidarTurn {
  double t_start_s = 0.0;
  uint32_t first = 0;  ///< index of its first sample
  uint32_t count = 0;
};

struct JointState {
  double t_s = 0.0;
  JointVector q = JointVector::Zero();  ///< [rad]
};

struct ScanLog {
  std::string source = "sim";         ///< sim | cell | rosbag1 | rosbag2
  std::string robot = "aubo_i5";      ///< robot name (URDF)
  std::string lidar_frame = "lidar";  ///< URDF link of the scan centre
  std::string lidar_model = "RPLIDAR A2M8";
  std::vector<std::string> joint_names;
  std::vector<LidarTurn> turns;
  std::vector<LidarSample> samples;
  std::vector<JointState> joints;  ///< strictly increasing in time

  /// Number of samples with a return.
  size_t valid_samples() const;

  /// Writes the file; throws std::runtime_error if it cannot be written.
  void write(const std::string& path) const;
  /// Reads and validates a file; throws InputError naming the file for anything malformed or truncated.
  static ScanLog read(const std::string& path);
};

}  // namespace weldtwin
