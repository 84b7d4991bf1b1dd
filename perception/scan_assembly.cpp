#include "perception/scan_assembly.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

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
  // knots are close in time (over a few milliseconds the arm's motion is a straight line to far under a
  // micrometre); exactly at the sample otherwise.
  const size_t step = static_cast<size_t>(std::max(1, setting.knot_samples));
  size_t knot_a = SIZE_MAX;
  bool knots = false;
  Iso3 Ta = Iso3::Identity(), Tb = Iso3::Identity();
  double ta = 0.0, tb = 0.0;
  for (size_t i = 0; i < log.samples.size(); ++i) {
    const LidarSample& s = log.samples[i];
    if (!usable(s, setting)) continue;
    if (step > 1 && i / step * step != knot_a) {
      const size_t a = i / step * step, b = a + step;  // past the last knot: every sample exactly
      const bool reuse = knots && a == knot_a + step;  // the last segment's end is this one's start
      if (reuse) Ta = Tb;
      knot_a = a;
      ta = log.samples[a].t_s;
      tb = b < log.samples.size() ? log.samples[b].t_s : ta;
      knots = tb > ta && tb - ta <= setting.max_knot_gap_s && (reuse || exact(a, Ta)) && exact(b, Tb);
    }
    Iso3 T = Ta;
    if (knots && s.t_s >= ta && s.t_s <= tb) {
      T = lerp_pose(Ta, Tb, (s.t_s - ta) / (tb - ta));
    } else if (!exact(i, T)) {
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
