// Where a sweep comes from, behind one interface that always yields the ScanLog of DESIGN.md:
//   sim        the twin's simulated sweep of the cell;
//   log:FILE   a recorded sweep: our ScanLog (.scanlog), a ROS 1 bag (.bag) or a ROS 2 bag (its directory or
//              .db3 file), told apart by their content;
//   lidar:DEV  a live RPLIDAR A2 on a serial port (not built yet: refused with a clear message).
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
/// is used by the `sim` source only. Throws InputError for an unknown kind or a lidar: source.
std::unique_ptr<ScanSource> make_scan_source(const std::string& spec, const RobotModel& robot,
                                             const SimScanInputs& sim);

/// Reads a recorded sweep of any of the log formats (told apart by content).
ScanLog read_any_scan_log(const std::string& path, const RobotModel& robot);

}  // namespace weldtwin
