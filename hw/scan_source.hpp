// Where a sweep comes from, behind one interface that always yields the ScanLog of docs/design.md:
//   sim        the twin's simulated sweep of the cell;
//   log:FILE   a recorded sweep: our ScanLog (.scanlog), a ROS 1 bag (.bag) or a ROS 2 bag (its directory or
//              .db3 file), told apart by their content;
//   lidar:DEV  a live RPLIDAR A2 on a serial port, scanning while the robot driver runs the sweep program;
//              samples and joint states are stamped on one clock (the host's), as they arrive.
// The perception and planning code downstream does not know which one it got.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/scan_log.hpp"
#include "sim/lidar_model.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/sweep_program.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {

/// What the `sim` source needs: the twin of the cell and its sweep.
struct SimScanInputs {
  const MujocoWorld* world = nullptr;
  const RobotModel* robot = nullptr;
  const SweepProgram* program = nullptr;
  LidarSetting lidar;
  SweepOptions options;
};

class RobotDriver;

/// What the `lidar:` source needs: the arm that carries the LiDAR through the sweep (connected).
struct LiveScanInputs {
  RobotDriver* driver = nullptr;
  const SweepProgram* program = nullptr;
  bool express = true;     ///< EXPRESS_SCAN (4000 samples/s on the A2) or SCAN (2000)
  double spinup_s = 2.0;   ///< the motor's time to reach a steady speed before the sweep starts
  double timeout_s = 1.0;  ///< silence from the device longer than this is an error
};

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  /// One line for progress output: what the scan comes from.
  virtual std::string describe() const = 0;
  /// The sweep. Throws InputError naming the file or device for bad input.
  virtual ScanLog acquire() = 0;
  /// Per-sample truth labels (only the twin has them; empty otherwise).
  virtual std::vector<Label> labels() const { return {}; }
};

/// The source named by `spec` (sim | log:FILE | lidar:DEV). `robot` orders the joints of recorded bags; `sim`
/// is used by the `sim` source only, `live` by `lidar:` only. Throws InputError for an unknown kind, or a
/// lidar: source without a robot driver.
std::unique_ptr<ScanSource> make_scan_source(const std::string& spec, const RobotModel& robot,
                                             const SimScanInputs& sim, const LiveScanInputs& live = {});

/// Reads a recorded sweep of any of the log formats (told apart by content).
ScanLog read_any_scan_log(const std::string& path, const RobotModel& robot);

}  // namespace weldtwin
