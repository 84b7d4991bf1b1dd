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

struct FixedRay;

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
  /// From cast_fixed_rays for this cell, robot, program, LiDAR and options: every sample's ray and its hit on
  /// the geometry all layouts share, so that only the layout's geoms (part, clamps, clutter) are cast
  /// against — the same sweep for less work (a randomized benchmark casts the shared part once per cell).
  /// Not with record_sensor_poses.
  const FixedRay* fixed_rays = nullptr;
  size_t fixed_ray_count = 0;
};

/// A sample's ray and where it first meets the geometry of the cell that its layout does not place: the
/// environment (table, walls, floor) and the arm, the same for every layout of the cell.
struct FixedRay {
  Vec3 origin = Vec3::Zero();  ///< the sensor at the sample's time, base frame
  Vec3 dir = Vec3::UnitX();    ///< unit
  double distance_m = -1.0;    ///< < 0: nothing within range
  double cos_incidence = 1.0;  ///< of the hit
  int geom = -1;               ///< MuJoCo geom id of the hit
};

struct SweepResult {
  ScanLog log;
  std::vector<Label> labels;       ///< per sample; kNone where there is no return
  std::vector<int> geoms;          ///< per sample: the geom hit, -1 for none or a mixed pixel
  std::vector<Iso3> T_base_lidar;  ///< per sample, when recorded
  double wall_s = 0.0;             ///< simulation wall time
};

/// Runs the sweep. The geometry a sample sees is posed at the start of the sample's slice
/// (SweepOptions::slice_s); the sensor itself at the sample's time (SweepOptions::sensor_knot_samples). Both
/// through the forward kinematics of the robot `world` was composed with (MujocoWorld::robot(): its LiDAR
/// mount is where the twin really has it); `robot` gives the log its robot and joint names.
SweepResult simulate_sweep(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                           const LidarSetting& lidar, const SweepOptions& options = {});

/// The number of samples simulate_sweep takes with these settings.
size_t sweep_sample_count(const SweepProgram& program, const LidarSetting& lidar,
                          const SweepOptions& options);

/// Every sample's ray cast against the part of `world` that its layout does not place (any layout of the
/// cell will do): `out` has sweep_sample_count() slots. For SweepOptions::fixed_rays.
void cast_fixed_rays(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                     const LidarSetting& lidar, const SweepOptions& options, FixedRay* out);

}  // namespace weldtwin
