// Closed-form IK against URDF forward kinematics over many seeded configurations, singular ones included.
#include "planning/ik_aubo.hpp"

#include <gtest/gtest.h>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

double angle_gap(const JointVector& a, const JointVector& b) {
  double worst = 0.0;
  for (int j = 0; j < 6; ++j) worst = std::max(worst, std::abs(std::remainder(a[j] - b[j], 2 * kPi)));
  return worst;
}

// Checks one configuration: every valid solution reproduces the pose, and q itself is among them.
void check(const RobotModel& robot, const AuboIk& ik, int tip, const JointVector& q, double& worst_pos,
           double& worst_rot, int& missed, double gap_tolerance = 1e-6) {
  const Iso3 T = robot.forward_kinematics(q, tip);
  const auto sols = ik.solve(T, q[5]);
  double best_gap = 1e9;
  for (const IkSolution& s : sols) {
    if (!s.valid) continue;
    const Iso3 T2 = robot.forward_kinematics(s.q, tip);
    worst_pos = std::max(worst_pos, (T2.translation() - T.translation()).norm());
    worst_rot = std::max(worst_rot, Eigen::AngleAxisd(T2.linear().transpose() * T.linear()).angle());
    best_gap = std::min(best_gap, angle_gap(s.q, q));
  }
  if (best_gap > gap_tolerance) {
    ++missed;
    std::printf("not recovered (gap %.2e rad): q =", best_gap);
    for (int j = 0; j < 6; ++j) std::printf(" %.12f", q[j]);
    std::printf("\n");
  }
}

TEST(AuboIk, RecoversPoseAndConfigurationFor100000RandomConfigurations) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const AuboIk ik(robot, "flange");
  const int flange = robot.require_link("flange");
  std::mt19937_64 rng(2025);
  double worst_pos = 0, worst_rot = 0;
  int missed = 0;
  for (int k = 0; k < 100000; ++k)
    check(robot, ik, flange, test::random_q(robot, rng), worst_pos, worst_rot, missed);
  std::printf("100000 random: worst position %.2e m, rotation %.2e rad, configurations not recovered %d\n",
              worst_pos, worst_rot, missed);
  EXPECT_LT(worst_pos, 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
  EXPECT_EQ(missed, 0);
}

TEST(AuboIk, WorksAtAndNearTheSingularities) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const AuboIk ik(robot, "tcp");
  const int tcp = robot.require_link("tcp");
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> tiny(-1e-3, 1e-3);
  double worst_pos = 0, worst_rot = 0;
  int missed = 0, cases = 0;
  const int wrist2 = robot.require_link("wrist2_Link"), upper = robot.require_link("upperArm_Link");
  for (int k = 0; k < 3000; ++k) {
    JointVector q = test::random_q(robot, rng);
    const double eps = k % 10 == 0 ? 0.0 : tiny(rng);  // exactly singular one time in ten
    if (k % 3 == 0) {
      q[4] = eps;  // wrist: J6 axis parallel to J2-J4
    } else if (k % 3 == 1) {
      q[2] = eps;  // straight elbow
    } else {
      // Shoulder: the wrist centre on the J1 axis's plane, found by bisection on q2.
      auto offset = [&](double q2) {
        JointVector qq = q;
        qq[1] = q2;
        std::vector<Iso3> fk;
        robot.forward_kinematics(qq, fk);
        const Vec3 lateral = fk[static_cast<size_t>(upper)].linear().col(2);
        return fk[static_cast<size_t>(wrist2)].translation().dot(Vec3::UnitZ().cross(lateral));
      };
      double lo = -kPi, hi = lo;
      for (double x = -kPi + 0.01; x < kPi; x += 0.01)
        if ((offset(x) > 0) != (offset(x - 0.01) > 0)) {
          lo = x - 0.01;
          hi = x;
          break;
        }
      if (hi == lo) continue;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        ((offset(mid) > 0) == (offset(lo) > 0) ? lo : hi) = mid;
      }
      q[1] = 0.5 * (lo + hi) + eps * 1e-3;
    }
    // A pose pins the configuration down only as well as the Jacobian is conditioned: within 1e-6 of a
    // singular configuration, configurations 1e-5 rad apart reach the same pose to 1e-12 m.
    check(robot, ik, tcp, q, worst_pos, worst_rot, missed, 1e-5);
    ++cases;
  }
  std::printf("%d near-singular: worst position %.2e m, rotation %.2e rad, not recovered %d\n", cases,
              worst_pos, worst_rot, missed);
  EXPECT_LT(worst_pos, 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
  EXPECT_EQ(missed, 0);
}

// One branch, or some of them, are those branches of all, to the bit; the branches not asked for are not
// given.
TEST(AuboIk, OneBranchOrSomeEqualThoseOfAll) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const AuboIk ik(robot, "tcp");
  std::mt19937_64 rng(9);
  for (int k = 0; k < 2000; ++k) {
    const Iso3 T = robot.forward_kinematics(test::random_q(robot, rng), robot.require_link("tcp"));
    const auto all = ik.solve(T, 0.2);
    const unsigned wanted = static_cast<unsigned>(rng() & 0xFFu);
    const auto some = ik.solve(T, 0.2, wanted);
    for (int b = 0; b < 8; ++b) {
      const IkSolution& of_all = all[static_cast<size_t>(b)];
      const IkSolution one = ik.solve_branch(T, b, 0.2);
      ASSERT_EQ(one.valid, of_all.valid);
      if (one.valid) {
        EXPECT_EQ(one.q, of_all.q);
      }
      const IkSolution& of_some = some[static_cast<size_t>(b)];
      if (!(wanted & (1u << b))) {
        EXPECT_FALSE(of_some.valid) << "branch " << b << " was not asked for";
        continue;
      }
      ASSERT_EQ(of_some.valid, of_all.valid);
      if (of_some.valid) {
        EXPECT_EQ(of_some.q, of_all.q);
        EXPECT_EQ(of_some.elbow_margin, of_all.elbow_margin);
      }
    }
  }
}

TEST(AuboIk, UnreachablePosesHaveNoSolution) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const AuboIk ik(robot, "flange");
  const Iso3 far = planar_pose(1.5, 0.0, 0.3, 0.0);
  for (const IkSolution& s : ik.solve(far)) EXPECT_FALSE(s.valid);
}

}  // namespace
}  // namespace weldtwin
