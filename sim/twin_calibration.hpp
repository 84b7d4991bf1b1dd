// The LiDAR mount found in the twin as a real cell finds it: the calibration cell (the bare table and the
// known box) swept through the LiDAR mount the cell really has, and the mount found from that sweep with the
// robot's nominal description (perception/mount_calibration). What `weldtwin bench --calibrate` and the
// localization survey's calibrated mount-error condition do before assembling a trial's scan.
#pragma once

#include <cstdint>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/mount_calibration.hpp"
#include "sim/sweep_program.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {

/// The calibration cell and what its sweep needs.
struct CalibrationCell {
  CellSpec cell;
  PartSpec box;
  Mesh box_mesh;
  SweepProgram program;
  /// The cell (scenes/cells/calibration.yaml, or that cell with another robot file) and the robot whose
  /// joints its sweep program moves.
  CalibrationCell(CellSpec cell, const RobotModel& robot);
};

/// Sweeps `cal` in the twin with the LiDAR where `real_robot` holds it (noise seeded by `lidar_seed`) and
/// finds the mount from that sweep with `nominal_robot`'s description.
MountCalibration calibrate_in_twin(const CalibrationCell& cal, const RobotModel& real_robot,
                                   const RobotModel& nominal_robot, uint64_t lidar_seed,
                                   const SweepOptions& options);

}  // namespace weldtwin
