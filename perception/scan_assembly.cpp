#include "perception/scan_assembly.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "core/knot_poses.hpp"

namespace weldtwin {
namespace {

Vec3 sample_point(const Iso3& T_base_lidar, const LidarSample& s) {
  const double a = static_cast<double>(s.angle_rad), r = static_cast<double>(s.range_m);
  return T_base_lidar * Vec3(r * std::cos(a), r * std::sin(a), 0.0);
}

bool usable(const LidarSample& s, const AssemblySetting& setting) {
  return s.range_m > 0.0f && s.quality >= setting.min_quality;
}

}  // namespace

bool interpolate_joints(const std::vector<JointState>& joints, double t, JointVector& q) {
  if (joints.empty() || t < joints.front().t_s || t > joints.back().t_s) return false;
  auto it = std::lower_bound(joints.begin(), joints.end(), t,
                             [](const JointState& j, double time) { return j.t_s < time; });
  if (it->t_s == t) {
    q = it->q;
    return true;
  }
  const JointState& b = *it;
  const JointState& a = *(it - 1);
  const double u = (t - a.t_s) / (b.t_s - a.t_s);
  q = a.q + u * (b.q - a.q);
  return true;
}

AssembledCloud assemble_scan(const ScanLog& log, const RobotModel& robot, const AssemblySetting& setting) {
  const int lidar = robot.link_index(log.lidar_frame);
  if (lidar < 0)
    throw std::invalid_argument("robot '" + robot.name() + "' has no link '" + log.lidar_frame + "'");
  if (log.joint_names != robot.joint_names())
    throw std::invalid_argument("scan log joints do not match robot '" + robot.name() + "'");
  AssembledCloud cloud;
  cloud.points_base.reserve(log.samples.size());
  cloud.sample_index.reserve(log.samples.size());
  cloud.viewpoints_base.reserve(log.samples.size());
  auto exact = [&](size_t i, Iso3& T) {
    JointVector q;
    if (!interpolate_joints(log.joints, log.samples[i].t_s, q)) return false;
    T = robot.forward_kinematics(q, lidar);
    return true;
  };
  // The sensor's pose exactly at every knot_samples-th sample, interpolated linearly in between when the two
  // knots are close in time; exactly at the sample otherwise.
  KnotPoses poses(log.samples.size(), static_cast<size_t>(std::max(1, setting.knot_samples)),
                  setting.max_knot_gap_s, exact, [&](size_t i) { return log.samples[i].t_s; });
  for (size_t i = 0; i < log.samples.size(); ++i) {
    const LidarSample& s = log.samples[i];
    if (!usable(s, setting)) continue;
    Iso3 T;
    if (!poses.pose(i, T)) {
      ++cloud.dropped_outside_joint_log;
      continue;
    }
    cloud.points_base.push_back(sample_point(T, s));
    cloud.viewpoints_base.push_back(T.translation());
    cloud.sample_index.push_back(static_cast<uint32_t>(i));
  }
  return cloud;
}

AssembledCloud assemble_scan(const ScanLog& log, const std::vector<Iso3>& T_base_lidar,
                             const AssemblySetting& setting) {
  if (T_base_lidar.size() != log.samples.size())
    throw std::invalid_argument("assemble_scan: one sensor pose per sample is needed");
  AssembledCloud cloud;
  for (size_t i = 0; i < log.samples.size(); ++i) {
    if (!usable(log.samples[i], setting)) continue;
    cloud.points_base.push_back(sample_point(T_base_lidar[i], log.samples[i]));
    cloud.viewpoints_base.push_back(T_base_lidar[i].translation());
    cloud.sample_index.push_back(static_cast<uint32_t>(i));
  }
  return cloud;
}

}  // namespace weldtwin
