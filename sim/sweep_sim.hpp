// Simulates a LiDAR sweep in the cell twin: the arm follows the sweep program (MuJoCo kinematics), every
// LiDAR sample is cast through Embree from the sensor pose at the sample's own timestamp, the LiDAR model
// turns exact hits into measurements, and the result is a ScanLog like a real cell records, plus what only
// the twin knows.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/scan_log.hpp"
#include "sim/lidar_model.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/sweep_program.hpp"

namespace weldtwin {

struct SweepOptions {
  double slice_s = 0.005;            ///< moving geometry is re-posed at the start of every slice [s]
  double joint_log_hz = 0.0;         ///< joint-state log rate; 0: the program's rate
  double max_duration_s = 0.0;       ///< stop early (tests); 0: the whole program
  int threads = 0;                   ///< 0: all cores
  bool record_sensor_poses = false;  ///< keep T_base_lidar of every sample (memory: 56 bytes a sample)
  bool cull_by_scan_plane = true;    ///< skip arm shapes the slice's scan planes cannot meet (same result)
  int sensor_knot_samples = 8;       ///< the sensor is posed exactly every this many samples, interpolated
                                     ///< linearly between (1: at every sample; 8 is 1 ms at 8 kHz)
  std::string lidar_link = "lidar";
  std::function<void(double done_fraction)> progress;  ///< called now and then from the calling thread
};

struct SweepResult {
  ScanLog log;
  std::vector<Label> labels;       ///< per sample; kNone where there is no return
  std::vector<int> geoms;          ///< per sample: the geom hit, -1 for none or a mixed pixel
  std::vector<Iso3> T_base_lidar;  ///< per sample, when recorded
  double wall_s = 0.0;             ///< simulation wall time
};

/// Runs the sweep. The geometry a sample sees is posed at the start of the sample's slice
/// (SweepOptions::slice_s); the sensor itself at the sample's time (SweepOptions::sensor_knot_samples).
SweepResult simulate_sweep(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                           const LidarSetting& lidar, const SweepOptions& options = {});

}  // namespace weldtwin
