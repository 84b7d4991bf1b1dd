#include "planning/ik_aubo.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace weldtwin {
namespace {

// Where an acos argument comes this close to +-1 the closed form loses digits and its answer is polished.
constexpr double kNearSingular = 1e-6;

// Rotation by angle q about the unit axis w (Rodrigues).
Mat3 rot(const Vec3& w, double q) {
  return Eigen::AngleAxisd(q, w).toRotationMatrix();
}

// Into (-pi, pi]; the closed form's angles are within a few turns of it.
double wrap(double a) {
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

// Subproblem 1: the angle turning u about axis w onto the direction of v (components normal to w).
// Returns false when either projection vanishes (the angle is then free).
bool angle_between(const Vec3& w, const Vec3& u, const Vec3& v, double& q) {
  const Vec3 up = u - w * w.dot(u), vp = v - w * w.dot(v);
  if (up.norm() < 1e-12 || vp.norm() < 1e-12) return false;
  q = std::atan2(w.dot(up.cross(vp)), up.dot(vp));
  return true;
}

// Solves a cos q + b sin q = c for both q; false if |c| exceeds sqrt(a^2 + b^2) beyond rounding.
// Near the boundary (a double root) both answers collapse to one.
bool cos_sin_equation(double a, double b, double c, double q[2], bool* near_double_root = nullptr,
                      double* sine = nullptr) {
  const double n = std::hypot(a, b);
  if (n < 1e-15) return false;
  double k = c / n;
  if (near_double_root) *near_double_root = 1.0 - std::abs(k) < kNearSingular;
  if (sine) *sine = std::sqrt(std::max(0.0, 1.0 - k * k));
  if (std::abs(k) > 1.0 + 1e-9) return false;
  k = std::clamp(k, -1.0, 1.0);
  const double phi = std::atan2(b, a), d = std::acos(k);
  q[0] = phi + d;
  q[1] = phi - d;
  return true;
}

// Coefficients of (Rot(w, q) v) . a = k0 + kc cos q + ks sin q.
void rotated_dot(const Vec3& w, const Vec3& v, const Vec3& a, double& k0, double& kc, double& ks) {
  const Vec3 par = w * w.dot(v);
  k0 = par.dot(a);
  kc = (v - par).dot(a);
  ks = w.cross(v).dot(a);
}

}  // namespace

AuboIk::AuboIk(const RobotModel& robot, const std::string& tip) {
  const JointVector zero = JointVector::Zero();
  std::vector<Iso3> home;
  robot.forward_kinematics(zero, home);
  int found = 0;
  for (size_t l = 0; l < robot.links().size(); ++l) {
    const RobotLink& link = robot.links()[l];
    if (link.q_index < 0) continue;
    w_[static_cast<size_t>(link.q_index)] = (home[l].linear() * link.axis).normalized();
    r_[static_cast<size_t>(link.q_index)] = home[l].translation();
    ++found;
  }
  if (found != 6) throw std::invalid_argument("AuboIk: the robot needs 6 revolute joints");
  M_ = home[static_cast<size_t>(robot.require_link(tip))];
  wp_ = w_[1];
  for (int i = 1; i <= 3; ++i) {
    if (w_[static_cast<size_t>(i)].cross(wp_).norm() > 1e-9)
      throw std::invalid_argument("AuboIk: joints 2-4 are not parallel");
    s_[static_cast<size_t>(i)] = w_[static_cast<size_t>(i)].dot(wp_) > 0 ? 1.0 : -1.0;
  }
  // Where the J5 and J6 axes meet: closest points of two lines.
  const Vec3 &a = w_[4], &b = w_[5], d = r_[5] - r_[4];
  const double ab = a.dot(b), den = 1.0 - ab * ab;
  if (den < 1e-12) throw std::invalid_argument("AuboIk: joints 5 and 6 are parallel");
  const double ta = (a.dot(d) - ab * b.dot(d)) / den, tb = (ab * a.dot(d) - b.dot(d)) / den;
  const Vec3 pa = r_[4] + ta * a, pb = r_[5] + tb * b;
  if ((pa - pb).norm() > 1e-9) throw std::invalid_argument("AuboIk: the J5 and J6 axes do not meet");
  W0_ = pa;
  w_tip_ = M_.inverse() * W0_;
  // Constants of the J5 equation and of the elbow triangle (J3 turning the J4 axis point about the J3 axis).
  rotated_dot(w_[4], w_[5], wp_, q5_const_, q5_cos_, q5_sin_);
  const Vec3 u = r_[3] - r_[2], v = r_[1] - r_[2], &w3 = w_[2];
  const Vec3 up = u - w3 * w3.dot(u), vp = v - w3 * w3.dot(v);
  elbow_nu_ = up.norm();
  elbow_nv_ = vp.norm();
  if (elbow_nu_ < 1e-9 || elbow_nv_ < 1e-9) throw std::invalid_argument("AuboIk: degenerate elbow");
  elbow_theta0_ = std::atan2(w3.dot(up.cross(vp)), up.dot(vp));
  wp_normal_ = wp_.unitOrthogonal();
  lower_ = robot.lower();
  upper_ = robot.upper();
}

std::array<IkSolution, 8> AuboIk::solve(const Iso3& T_base_tip, double q6_reference,
                                        unsigned branches) const {
  std::array<IkSolution, 8> out;
  solve_into(T_base_tip, q6_reference, branches, out);
  return out;
}

IkSolution AuboIk::solve_branch(const Iso3& T_base_tip, int branch, double q6_reference) const {
  std::array<IkSolution, 8> out;
  solve_into(T_base_tip, q6_reference, 1u << branch, out);
  return out[static_cast<size_t>(branch)];
}

void AuboIk::solve_into(const Iso3& T_base_tip, double q6_reference, unsigned branches,
                        std::array<IkSolution, 8>& out) const {
  const Mat3& R = T_base_tip.linear();
  // The wrist centre, where the J5 and J6 axes meet: fixed in the tip frame.
  const Vec3 W = T_base_tip * w_tip_;

  // J1: rotations about J2-J4 keep every point's coordinate along wp, so
  // (Rot(w1, q1) wp) . (W - r1) = wp . (W0 - r1).
  double k0, kc, ks, q1s[2], shoulder_sine = 0.0, wrist_sine = 0.0;
  bool shoulder_singular = false, wrist_singular = false;
  rotated_dot(w_[0], wp_, W - r_[0], k0, kc, ks);
  if (!cos_sin_equation(kc, ks, wp_.dot(W0_ - r_[0]) - k0, q1s, &shoulder_singular, &shoulder_sine)) return;

  const Vec3 w6_now = R * M_.linear().transpose() * w_[5];  // J6 axis at the target
  for (int i1 = 0; i1 < 2; ++i1) {
    if (!(branches & (0xFu << (4 * i1)))) continue;
    const double q1 = q1s[i1];
    const Mat3 R1 = rot(w_[0], q1);
    // J5: (Rot(w5, q5) w6) . wp = (R1 wp) . w6_now.
    double q5s[2];
    if (!cos_sin_equation(q5_cos_, q5_sin_, (R1 * wp_).dot(w6_now) - q5_const_, q5s, &wrist_singular,
                          &wrist_sine))
      continue;
    const Mat3 N = R1.transpose() * R * M_.linear().transpose();  // = R234 R5 R6
    for (int i5 = 0; i5 < 2; ++i5) {
      if (!(branches & (0x3u << (4 * i1 + 2 * i5)))) continue;
      const double q5 = q5s[i5];
      const Mat3 R5 = rot(w_[4], q5);
      // J6 turns N^T wp onto R5^T wp; at the wrist singularity both lie on the J6 axis and J6 is free.
      double q6 = q6_reference;
      angle_between(w_[5], N.transpose() * wp_, R5.transpose() * wp_, q6);
      const Mat3 R234 = N * (R5 * rot(w_[5], q6)).transpose();
      // The angle of R234 about wp.
      const Vec3& e = wp_normal_;
      const double theta = std::atan2(wp_.dot(e.cross(R234 * e)), e.dot(R234 * e));
      // J3 then J2 from the J4 axis point (Subproblems 3 and 1).
      const Vec3 P4 = W - R1 * R234 * (W0_ - r_[3]);
      const Vec3 P4b = R1.transpose() * (P4 - r_[0]) + r_[0];  // as if q1 = 0
      const Vec3& w3 = w_[2];
      const double along = w3.dot(P4b - r_[1]);
      const double delta2 = (P4b - r_[1]).squaredNorm() - along * along;
      double kappa = (elbow_nu_ * elbow_nu_ + elbow_nv_ * elbow_nv_ - delta2) / (2.0 * elbow_nu_ * elbow_nv_);
      if (std::abs(kappa) > 1.0 + 1e-9) continue;  // out of reach for this shoulder and wrist
      kappa = std::clamp(kappa, -1.0, 1.0);
      const bool elbow_singular = 1.0 - std::abs(kappa) < kNearSingular;
      const double elbow_angle = std::acos(kappa), elbow_sine = std::sqrt(std::max(0.0, 1.0 - kappa * kappa));
      for (int i3 = 0; i3 < 2; ++i3) {
        if (!(branches & (1u << (4 * i1 + 2 * i5 + i3)))) continue;
        const double q3 = elbow_theta0_ + (i3 == 0 ? -1.0 : 1.0) * elbow_angle;
        const Vec3 p3 = r_[2] + rot(w3, q3) * (r_[3] - r_[2]);
        double q2 = 0.0;
        angle_between(w_[1], p3 - r_[1], P4b - r_[1], q2);
        const double q4 = s_[3] * (theta - s_[1] * q2 - s_[2] * q3);
        IkSolution& sol = out[static_cast<size_t>(4 * i1 + 2 * i5 + i3)];
        sol.q << q1, q2, q3, q4, q5, q6;
        if (shoulder_singular || wrist_singular || elbow_singular) polish(T_base_tip, sol.q);
        for (int j = 0; j < 6; ++j) sol.q[j] = wrap(sol.q[j]);
        sol.valid = true;
        sol.within_limits = ((sol.q - lower_).array() >= 0).all() && ((upper_ - sol.q).array() >= 0).all();
        sol.branch = 4 * i1 + 2 * i5 + i3;
        sol.shoulder_margin = shoulder_sine;
        sol.wrist_margin = wrist_sine;
        sol.elbow_margin = elbow_sine;
      }
    }
  }
}

void AuboIk::polish(const Iso3& T_target, JointVector& q) const {
  // The closed form loses digits where an acos argument nears +-1 (straight elbow, shoulder and wrist
  // singularities): a few damped Gauss-Newton steps on the geometric Jacobian restore full precision.
  for (int iter = 0; iter < 4; ++iter) {
    // Joint axes and points at q, tip pose, by the product of exponentials.
    Iso3 T = Iso3::Identity();
    Eigen::Matrix<double, 6, 6> J;
    for (int i = 0; i < 6; ++i) {
      const size_t k = static_cast<size_t>(i);
      const Vec3 a = T.linear() * w_[k], p = T * r_[k];
      J.block<3, 1>(0, i) = a;
      J.block<3, 1>(3, i) = p;  // completed below, once the tip is known
      const Mat3 R = rot(w_[k], q[i]);
      Iso3 E = Iso3::Identity();
      E.linear() = R;
      E.translation() = r_[k] - R * r_[k];
      T = T * E;
    }
    const Iso3 tip = T * M_;
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = Eigen::AngleAxisd(T_target.linear() * tip.linear().transpose()).angle() *
                  Eigen::AngleAxisd(T_target.linear() * tip.linear().transpose()).axis();
    e.tail<3>() = T_target.translation() - tip.translation();
    if (e.head<3>().norm() < 1e-14 && e.tail<3>().norm() < 1e-14) return;
    for (int i = 0; i < 6; ++i) {
      const Vec3 a = J.block<3, 1>(0, i), p = J.block<3, 1>(3, i);
      J.block<3, 1>(3, i) = a.cross(tip.translation() - p);
    }
    const Eigen::Matrix<double, 6, 6> A = J * J.transpose() + 1e-12 * Eigen::Matrix<double, 6, 6>::Identity();
    q += J.transpose() * A.ldlt().solve(e);
  }
}

bool AuboIk::nearest(const Iso3& T_base_tip, const JointVector& q_near, JointVector& q) const {
  double best = 1e300;
  for (const IkSolution& s : solve(T_base_tip, q_near[5])) {
    if (!s.valid || !s.within_limits) continue;
    const double d = (s.q - q_near).cwiseAbs().maxCoeff();
    if (d < best) {
      best = d;
      q = s.q;
    }
  }
  return best < 1e300;
}

}  // namespace weldtwin
