// `weldtwin scan`: simulate the cell's sweep and write the ScanLog, optionally the base-frame cloud (PCD) and
// the twin's ground truth (JSON).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace weldtwin {

struct ScanCommand {
  std::string cell;
  std::optional<uint64_t> seed;
  std::string out_log;
  std::string cloud;    ///< "" = none
  std::string truth;    ///< "" = none
  std::string mjcf;     ///< "" = none: where to save the composed MJCF
  std::string rosbag1;  ///< "" = none: the sweep as a ROS 1 bag too (/scan, /joint_states)
  std::string rosbag2;  ///< "" = none: the sweep as a ROS 2 bag directory too (sqlite3, CDR)
  std::string rosbag2_storage = "sqlite3";  ///< the ROS 2 bag's storage: sqlite3 or mcap
  bool noise_free = false;
  int threads = 0;
  bool quiet = false;
};

/// Runs the command; returns the process exit code. Throws InputError for bad input.
int run_scan(const ScanCommand& cmd);

}  // namespace weldtwin
