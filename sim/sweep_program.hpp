// A sweep program (scenes/sweeps/*.yaml): joint-space waypoints reached one after the other, each move timed
// as a linear segment with parabolic blends (LSPB), starting and ending at rest. The LiDAR records
// throughout.
#pragma once

#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace weldtwin {

struct SweepMove {
  std::string name;
  JointVector to = JointVector::Zero();  ///< [rad]
  double duration_s = 0.0;
};

struct JointSample {
  JointVector q, qd, qdd;  ///< [rad], [rad/s], [rad/s^2]
};

class SweepProgram {
 public:
  /// Loads and checks against the robot's limits; throws InputError naming the file, the move and the joint.
  static SweepProgram load(const std::string& yaml_path, const RobotModel& robot);
  /// Builds a program from moves (checked like a file; `source` names it in errors).
  SweepProgram(std::string source, JointVector start, std::vector<SweepMove> moves, double blend_fraction,
               double joint_log_hz, const RobotModel& robot);

  const std::string& source() const { return source_; }
  const JointVector& start() const { return start_; }
  const std::vector<SweepMove>& moves() const { return moves_; }
  double duration_s() const { return end_times_.empty() ? 0.0 : end_times_.back(); }
  double blend_fraction() const { return blend_; }
  double joint_log_hz() const { return joint_log_hz_; }
  /// The largest |qdd| of any joint anywhere in the program [rad/s^2].
  double max_abs_acceleration() const { return max_acc_; }

  /// Joint state at time t (clamped to [0, duration]).
  JointSample at(double t) const;
  JointVector q(double t) const { return at(t).q; }

 private:
  std::string source_;
  JointVector start_;
  std::vector<SweepMove> moves_;
  std::vector<double> end_times_;
  double blend_ = 0.2;
  double joint_log_hz_ = 200.0;
  double max_acc_ = 0.0;
};

}  // namespace weldtwin
