// Closed-form inverse kinematics of the Aubo i5 (and any arm of its family: J1, then three parallel joints,
// then a wrist whose last two axes intersect), by the product of exponentials and Paden-Kahan subproblems.
// The joint axes, their points and the home pose are read from the URDF, so the solver follows the model.
// Up to 8 solutions; at the wrist singularity (J6 axis parallel to J2-J4) J6 is free and takes a reference
// value, so the solver still answers there, as it does at a straight elbow and at the shoulder singularity.
#pragma once

#include <array>
#include <string>

#include "core/robot_model.hpp"

namespace weldtwin {

struct IkSolution {
  JointVector q = JointVector::Zero();  ///< each angle in (-pi, pi]
  bool valid = false;                   ///< this branch reaches the pose
  bool within_limits = false;           ///< and every joint is inside its limits
  int branch = 0;                       ///< 4 * shoulder + 2 * wrist + elbow
  /// Distance from the three singularities, each the sine of the angle between the two branches it
  /// separates (0 at the singularity, 1 farthest): shoulder (wrist centre on the J1 axis's offset cylinder),
  /// elbow (arm straight), wrist (J6 axis parallel to J2-J4).
  double shoulder_margin = 0.0, elbow_margin = 0.0, wrist_margin = 0.0;
};

class AuboIk {
 public:
  /// Reads the kinematics from `robot` for the pose of link `tip` (e.g. "flange" or "tcp"). Throws
  /// std::invalid_argument if the robot is not of this family.
  AuboIk(const RobotModel& robot, const std::string& tip);

  /// Every solution for T_base_tip. `q6_reference` is J6 where it is free (at the wrist singularity).
  /// `branches`: a bit per branch wanted (the others are left invalid, their work not done).
  std::array<IkSolution, 8> solve(const Iso3& T_base_tip, double q6_reference = 0.0,
                                  unsigned branches = 0xFFu) const;

  /// One branch only (0..7), about a quarter of the work of solve().
  IkSolution solve_branch(const Iso3& T_base_tip, int branch, double q6_reference = 0.0) const;

  /// The valid solution within limits nearest to `q_near` (max-norm over joints); false if there is none.
  bool nearest(const Iso3& T_base_tip, const JointVector& q_near, JointVector& q) const;

 private:
  void solve_into(const Iso3& T_base_tip, double q6_reference, unsigned branches,
                  std::array<IkSolution, 8>& out) const;
  void polish(const Iso3& T_target, JointVector& q) const;

  std::array<Vec3, 6> w_;      ///< joint axes at home, base frame
  std::array<Vec3, 6> r_;      ///< a point on each axis at home
  Iso3 M_ = Iso3::Identity();  ///< tip pose at home
  Vec3 wp_ = Vec3::Zero();     ///< the common direction of J2-J4
  std::array<double, 6> s_{};  ///< w_i . wp_ for i = 1..3 (+-1), others unused
  Vec3 W0_ = Vec3::Zero();     ///< where the J5 and J6 axes meet, at home
  Vec3 w_tip_ = Vec3::Zero();  ///< that point in the tip frame
  JointVector lower_, upper_;
  double q5_const_ = 0, q5_cos_ = 0, q5_sin_ = 0;  ///< (Rot(w5, q5) w6) . wp = const + cos q5 + sin q5
  double elbow_nu_ = 0, elbow_nv_ = 0, elbow_theta0_ = 0;  ///< the elbow triangle
  Vec3 wp_normal_ = Vec3::UnitX();                         ///< a unit vector normal to wp
};

}  // namespace weldtwin
