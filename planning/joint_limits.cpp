// The joint velocity and acceleration of a trajectory by finite differences, against the robot's limits.
#include <cmath>
#include <string>
#include <vector>

#include "planning/weld_planner.hpp"

namespace weldtwin {

std::vector<std::string> check_joint_limits(const std::vector<PlanSample>& samples, const RobotModel& robot,
                                            double sample_hz) {
  return check_joint_limits(samples.data(), samples.size(), robot, sample_hz);
}

std::vector<std::string> check_joint_limits(const PlanSample* first, size_t count, const RobotModel& robot,
                                            double sample_hz) {
  const auto samples = [&](size_t k) -> const PlanSample& { return first[k]; };
  std::vector<std::string> out;
  double worst_v[6] = {0}, worst_a[6] = {0};
  int at_v[6] = {0}, at_a[6] = {0};
  for (size_t k = 0; k < count; ++k) {
    const JointVector& q = samples(k).q;
    for (int j = 0; j < 6; ++j)
      if (q[j] < robot.lower()[j] || q[j] > robot.upper()[j]) {
        out.push_back("joint " + std::to_string(j + 1) +
                      " leaves its limits at t = " + std::to_string(samples(k).t_s) + " s");
        return out;
      }
    if (k + 1 < count) {
      const JointVector v = (samples(k + 1).q - q) * sample_hz;
      for (int j = 0; j < 6; ++j)
        if (std::abs(v[j]) > worst_v[j]) {
          worst_v[j] = std::abs(v[j]);
          at_v[j] = static_cast<int>(k);
        }
    }
    if (k > 0 && k + 1 < count) {
      const JointVector a = (samples(k + 1).q - 2.0 * q + samples(k - 1).q) * sample_hz * sample_hz;
      for (int j = 0; j < 6; ++j)
        if (std::abs(a[j]) > worst_a[j]) {
          worst_a[j] = std::abs(a[j]);
          at_a[j] = static_cast<int>(k);
        }
    }
  }
  // A small tolerance for the finite differences of exact LSPB profiles.
  for (int j = 0; j < 6; ++j) {
    if (worst_v[j] > robot.max_velocity()[j] * 1.001)
      out.push_back("joint " + std::to_string(j + 1) + " needs " + std::to_string(worst_v[j]) +
                    " rad/s at t = " + std::to_string(samples(static_cast<size_t>(at_v[j])).t_s) +
                    " s (limit " + std::to_string(robot.max_velocity()[j]) + ")");
    if (worst_a[j] > robot.max_acceleration()[j] * 1.001)
      out.push_back("joint " + std::to_string(j + 1) + " needs " + std::to_string(worst_a[j]) +
                    " rad/s^2 at t = " + std::to_string(samples(static_cast<size_t>(at_a[j])).t_s) +
                    " s (limit " + std::to_string(robot.max_acceleration()[j]) + ")");
  }
  return out;
}

}  // namespace weldtwin
