// `weldtwin run`: the whole job in the twin — simulated sweep, localization, plan, replay in MuJoCo — and a
// report a welding engineer would read (DIR/report.html, DIR/report.json), with a one-line verdict.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace weldtwin {

struct RunCommand {
  std::string cell;  ///< cell YAML ("" = scenes/cells/default.yaml)
  std::optional<uint64_t> seed;
  std::string out = "out/run";
  bool renders = true;  ///< OSMesa pictures and plots in the report (off: figures only, faster)
  bool quiet = false;
  bool guidance =
      true;  ///< when the part does not weld where it lies, find where it would (and map the table)
  int threads = 0;
  std::string source = "sim";                           ///< sim | log:FILE | lidar:DEV (hw/scan_source.hpp)
  std::vector<double> mount_error_mm, mount_error_deg;  ///< twin only: the LiDAR's real mount is off by this
  std::string
      lidar_mount;  ///< mount JSON of weldtwin calibrate: the scan is assembled with the corrected mount
  std::string robot = "sim";     ///< sim | aubo://HOST (hw/robot_driver.hpp): the arm that sweeps and welds
  bool robot_given = false;      ///< --robot on the command line: show the dry run (or execute)
  bool execute = false;          ///< send the passed plan to the robot (and let a live sweep move the arm)
  double speed_fraction = 1.0;   ///< speed override on the robot
  double robot_timeout_s = 2.0;  ///< every exchange with the robot controller
};

/// Returns the exit code: 0 PASS, 3 FAIL (the report says why; also a refused gate or a robot error),
/// 130 stopped by SIGINT. Throws InputError for bad input.
int run_job(const RunCommand& cmd);

struct ReplayCommand {
  std::string plan;  ///< plan JSON
  std::string cell;  ///< "" = the default cell; its part at the cell's pose (or drawn from the seed)
  std::optional<uint64_t> seed;
  std::string out = "out/replay";
  bool renders = true;
  bool quiet = false;
};

/// Replays a plan in the cell and writes the report: 0 the replay passed, 3 it failed.
int run_replay(const ReplayCommand& cmd);

}  // namespace weldtwin
