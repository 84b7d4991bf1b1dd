#include "hw/tf_joints.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/error.hpp"

namespace weldtwin {
namespace {

constexpr double kOriginTolerance_m = 1e-4;  // a joint's transform must turn about the URDF's origin
constexpr double kAxisTolerance_rad = 1e-4;  // and about its axis

std::string frame(const std::string& name) {
  return !name.empty() && name[0] == '/' ? name.substr(1) : name;
}

/// A frame's name for a message (a recording's names can be anything, of any length).
std::string shown(const std::string& name) {
  return name.size() <= 60 ? name : name.substr(0, 57) + "...";
}

/// The angle by which R turns about `axis`, and how far R is from that turn [rad].
double angle_about(const Mat3& R, const Vec3& axis, double& off_rad) {
  const Vec3 v(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));  // 2 sin(q) * the turn's axis
  const double q = std::atan2(0.5 * axis.dot(v), 0.5 * (R.trace() - 1.0));
  const Eigen::AngleAxisd rest(R * Eigen::AngleAxisd(-q, axis).toRotationMatrix());
  off_rad = std::abs(rest.angle());
  return q;
}

}  // namespace

std::vector<StampedJoints> joints_from_tf(const std::vector<TfTransform>& tf, const RobotModel& robot,
                                          const std::string& file) {
  const std::vector<RobotLink>& links = robot.links();
  std::map<std::pair<std::string, std::string>, std::vector<const TfTransform*>> edges;
  for (const TfTransform& t : tf) edges[{frame(t.parent), frame(t.child)}].push_back(&t);

  // Every actuated joint's angle over time, unwrapped by continuity.
  std::vector<std::vector<std::pair<int64_t, double>>> series(static_cast<size_t>(robot.dof()));
  for (const RobotLink& l : links) {
    if (l.q_index < 0) continue;
    const std::string& parent = links[static_cast<size_t>(l.parent)].name;
    const auto it = edges.find({parent, l.name});
    if (it == edges.end()) {
      std::string have;
      int listed = 0;
      for (const auto& [e, v] : edges)
        if (listed++ < 8) have += (have.empty() ? "" : ", ") + shown(e.first) + " -> " + shown(e.second);
      throw input_error(file, "the /tf recording has no transform from " + parent + " to " + l.name +
                                  " (the robot's joint '" + l.joint_name + "'); it has " +
                                  (have.empty() ? std::string("none") : have) +
                                  (edges.size() > 8 ? ", ..." : ""));
    }
    std::vector<const TfTransform*> samples = it->second;
    std::stable_sort(samples.begin(), samples.end(),
                     [](const TfTransform* a, const TfTransform* b) { return a->stamp_ns < b->stamp_ns; });
    const Iso3 origin_inv = l.T_parent_joint.inverse();
    auto& s = series[static_cast<size_t>(l.q_index)];
    for (const TfTransform* t : samples) {
      const Iso3 turn = origin_inv * t->T_parent_child;
      double off = 0.0;
      double q = angle_about(turn.rotation(), l.axis, off);
      const double moved = turn.translation().norm();
      if (!(moved < kOriginTolerance_m) || !(off < kAxisTolerance_rad)) {
        char b[240];
        std::snprintf(
            b, sizeof b,
            "the /tf transform from %s to %s is not the robot's joint '%s' (%.2f mm from its origin, "
            "%.3f deg off its axis): another robot description?",
            parent.c_str(), l.name.c_str(), l.joint_name.c_str(), moved * 1e3, off * 180 / kPi);
        throw input_error(file, b);
      }
      if (!s.empty()) {
        if (s.back().first == t->stamp_ns) s.pop_back();  // the last transform of a stamp holds
        if (!s.empty()) q += 2 * kPi * std::round((s.back().second - q) / (2 * kPi));
      }
      s.emplace_back(t->stamp_ns, q);
    }
  }

  // Sampled at the first joint's stamps, within every joint's span.
  std::vector<StampedJoints> out;
  std::vector<size_t> cursor(series.size(), 0);
  for (const auto& [stamp, q0] : series[0]) {
    StampedJoints j;
    j.stamp_ns = stamp;
    bool inside = true;
    for (size_t k = 0; k < series.size() && inside; ++k) {
      const auto& s = series[k];
      if (stamp < s.front().first || stamp > s.back().first) {
        inside = false;
        break;
      }
      size_t& c = cursor[k];
      while (c + 1 < s.size() && s[c + 1].first <= stamp) ++c;
      if (s[c].first == stamp || c + 1 == s.size()) {
        j.q[static_cast<int>(k)] = s[c].second;
      } else {
        const double u =
            static_cast<double>(stamp - s[c].first) / static_cast<double>(s[c + 1].first - s[c].first);
        j.q[static_cast<int>(k)] = (1 - u) * s[c].second + u * s[c + 1].second;
      }
    }
    if (inside) out.push_back(j);
  }
  if (out.empty()) throw input_error(file, "the /tf recording's joints never overlap in time");
  return out;
}

std::vector<TfTransform> tf_of_joints(int64_t stamp_ns, const JointVector& q, const RobotModel& robot,
                                      bool moving) {
  std::vector<TfTransform> out;
  for (const RobotLink& l : robot.links()) {
    if (l.parent < 0 || (l.q_index >= 0) != moving) continue;
    TfTransform t;
    t.stamp_ns = stamp_ns;
    t.parent = robot.links()[static_cast<size_t>(l.parent)].name;
    t.child = l.name;
    t.T_parent_child = l.T_parent_joint;
    if (l.q_index >= 0) t.T_parent_child.rotate(Eigen::AngleAxisd(q[l.q_index], l.axis));
    out.push_back(t);
  }
  return out;
}

}  // namespace weldtwin
