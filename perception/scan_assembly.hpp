// Scan assembly, shared by simulated and real sweeps: ScanLog + robot forward kinematics + LiDAR extrinsics
// (the URDF's lidar link) -> a base-frame point cloud. Joint states are interpolated linearly at each
// sample's own time, so the arm may move during a turn.
#pragma once

#include <cstdint>
#include <vector>

#include "core/robot_model.hpp"
#include "core/scan_log.hpp"

namespace weldtwin {

struct AssemblySetting {
  uint8_t min_quality = 1;       ///< samples below this quality are dropped (0 = no return)
  int knot_samples = 8;          ///< the sensor pose is computed (joint log, FK) exactly at every this many
                                 ///< samples and interpolated between (1: at every sample)
  double max_knot_gap_s = 0.01;  ///< knots farther apart in time: every sample between is posed exactly
};

struct AssembledCloud {
  std::vector<Vec3> points_base;         ///< [m], base frame
  std::vector<uint32_t> sample_index;    ///< the ScanLog sample each point came from
  std::vector<Vec3> viewpoints_base;     ///< [m], base frame: where the sensor was when it saw each point
  size_t dropped_outside_joint_log = 0;  ///< samples with no joint state before and after them
};

/// Assembles through FK of the logged joint states. Throws std::invalid_argument if the robot has no link
/// named by the log's lidar frame, or if the log's joint names differ from the robot's.
AssembledCloud assemble_scan(const ScanLog& log, const RobotModel& robot,
                             const AssemblySetting& setting = {});

/// Assembles with a known sensor pose for every sample (e.g. the twin's own), T_base_lidar[i] for sample i.
AssembledCloud assemble_scan(const ScanLog& log, const std::vector<Iso3>& T_base_lidar,
                             const AssemblySetting& setting = {});

/// Linear interpolation of the joint log at time t; false if t is outside the log.
bool interpolate_joints(const std::vector<JointState>& joints, double t, JointVector& q);

}  // namespace weldtwin
