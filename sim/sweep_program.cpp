#include "sim/sweep_program.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.hpp"
#include "core/yaml_util.hpp"
#include "planning/lspb.hpp"

namespace weldtwin {
namespace {

JointVector degrees(const YAML::Node& node, const std::string& key, const std::string& file) {
  auto v = yaml::numbers(node, key, 6, file);
  JointVector q;
  for (int i = 0; i < 6; ++i) q[i] = deg2rad(v[static_cast<size_t>(i)]);
  return q;
}

}  // namespace

SweepProgram::SweepProgram(std::string source, JointVector start, std::vector<SweepMove> moves,
                           double blend_fraction, double joint_log_hz, const RobotModel& robot)
    : source_(std::move(source)),
      start_(start),
      moves_(std::move(moves)),
      blend_(blend_fraction),
      joint_log_hz_(joint_log_hz) {
  if (moves_.empty()) throw input_error(source_, "sweep has no moves");
  if (!(blend_ > 0.0 && blend_ <= 0.5)) throw input_error(source_, "blend_fraction must be in (0, 0.5]");
  if (!(joint_log_hz_ > 0.0)) throw input_error(source_, "joint_log_hz must be positive");
  auto check_limits = [&](const JointVector& q, const std::string& where) {
    for (int j = 0; j < 6; ++j)
      if (q[j] < robot.lower()[j] || q[j] > robot.upper()[j]) {
        std::ostringstream os;
        os << where << ": joint " << j + 1 << " at " << rad2deg(q[j]) << " deg is outside its limits";
        throw input_error(source_, os.str());
      }
  };
  check_limits(start_, "start");
  JointVector from = start_;
  double t = 0.0;
  for (const SweepMove& m : moves_) {
    const std::string where = "move '" + m.name + "'";
    check_limits(m.to, where);
    if (!(m.duration_s > 0.0)) throw input_error(source_, where + ": duration must be positive");
    const double tb = blend_ * m.duration_s;
    for (int j = 0; j < 6; ++j) {
      const double dq = std::abs(m.to[j] - from[j]);
      const double v = dq / (m.duration_s - tb), a = v / tb;
      max_acc_ = std::max(max_acc_, a);
      if (v > robot.max_velocity()[j] || a > robot.max_acceleration()[j]) {
        std::ostringstream os;
        os << where << ": joint " << j + 1 << " needs " << v << " rad/s and " << a
           << " rad/s^2, beyond its limits; make the move longer";
        throw input_error(source_, os.str());
      }
    }
    t += m.duration_s;
    end_times_.push_back(t);
    from = m.to;
  }
  // A sweep's log grows with its length (8000 samples a second): a program of hours is a typo, not a sweep.
  constexpr double kMaxSweepSeconds = 900.0;
  if (t > kMaxSweepSeconds) {
    std::ostringstream os;
    os << "the sweep lasts " << t << " s (" << moves_.size() << " moves); at most " << kMaxSweepSeconds
       << " s (the eight-pass default takes 181 s)";
    throw input_error(source_, os.str());
  }
}

SweepProgram SweepProgram::load(const std::string& yaml_path, const RobotModel& robot) {
  try {
    const YAML::Node root = yaml::load_file(yaml_path);
    const JointVector start = degrees(root, "start_deg", yaml_path);
    const YAML::Node moves = root["moves"];
    if (!moves || !moves.IsSequence()) throw input_error(yaml_path, "missing list 'moves'");
    std::vector<SweepMove> out;
    for (size_t i = 0; i < moves.size(); ++i) {
      SweepMove m;
      m.name = moves[i]["name"] ? yaml::text(moves[i], "name", yaml_path) : "#" + std::to_string(i);
      m.to = degrees(moves[i], "to_deg", yaml_path);
      m.duration_s = yaml::number(moves[i], "duration_s", yaml_path);
      out.push_back(m);
    }
    return SweepProgram(yaml_path, start, std::move(out),
                        yaml::maybe_number(root, "blend_fraction", yaml_path).value_or(0.2),
                        yaml::maybe_number(root, "joint_log_hz", yaml_path).value_or(200.0), robot);
  } catch (const YAML::Exception& e) {
    throw input_error(yaml_path, "malformed sweep program: " + e.msg);
  }
}

JointSample SweepProgram::at(double t) const {
  t = std::clamp(t, 0.0, duration_s());
  const size_t i =
      static_cast<size_t>(std::lower_bound(end_times_.begin(), end_times_.end(), t) - end_times_.begin());
  const size_t k = std::min(i, moves_.size() - 1);
  const double t0 = k == 0 ? 0.0 : end_times_[k - 1];
  const JointVector& from = k == 0 ? start_ : moves_[k - 1].to;
  const JointVector delta = moves_[k].to - from;
  // The unit move 0 -> 1 in the move's time, blends a fraction of it at both ends (planning/lspb.hpp).
  const double T = moves_[k].duration_s;
  const Lspb law = Lspb::with_blend_fraction(1.0, 1.0 / (T * (1.0 - blend_)), blend_);
  double s, sd, sdd;
  law.at(t - t0, s, sd, sdd);
  return {from + s * delta, sd * delta, sdd * delta};
}

}  // namespace weldtwin
