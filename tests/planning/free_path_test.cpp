// The free joint-space path: free, between the asked ends, and the same for the same question whatever was
// asked before in the process.
#include "planning/free_path.hpp"

#include <gtest/gtest.h>

namespace weldtwin {
namespace {

// A wall across joint 1 with a gap to go round: straight paths through it are blocked, so RRT-Connect
// samples (and its answer depends on its random numbers).
bool free_of_wall(const JointVector& q) {
  return !(std::abs(q[0]) < 0.3 && q[1] < 1.0 && q[1] > -2.5 && q[2] > -2.0);
}

JointVector joints(double a, double b, double c) {
  JointVector q = JointVector::Zero();
  q[0] = a, q[1] = b, q[2] = c;
  return q;
}

TEST(FreePath, FreeBetweenTheEndsAndTheSameAnswerWhateverWasAskedBefore) {
  const JointVector lower = JointVector::Constant(-3.0), upper = JointVector::Constant(3.0);
  const JointVector a = joints(-1.0, 0.0, 0.0), b = joints(1.0, 0.0, 0.0);
  const double resolution = 0.02;
  const std::vector<JointVector> first = free_joint_path(a, b, lower, upper, free_of_wall, resolution);
  ASSERT_GE(first.size(), 3u);  // round the wall, not through it
  EXPECT_EQ(first.front(), a);
  EXPECT_EQ(first.back(), b);
  for (size_t k = 1; k < first.size(); ++k) {
    const JointVector& p = first[k - 1];
    const JointVector& q = first[k];
    const int steps = static_cast<int>(std::ceil((q - p).norm() / resolution)) + 1;
    for (int s = 0; s <= steps; ++s)
      ASSERT_TRUE(free_of_wall(p + (q - p) * (static_cast<double>(s) / steps))) << "segment " << k;
  }
  // Other questions in between, then the first again.
  for (int k = 0; k < 3; ++k)
    EXPECT_FALSE(
        free_joint_path(joints(-1.0, 0.1 * k, 0.0), joints(1.2, -0.1 * k, 0.3), lower, upper, free_of_wall)
            .empty());
  const std::vector<JointVector> again = free_joint_path(a, b, lower, upper, free_of_wall, resolution);
  ASSERT_EQ(again.size(), first.size());
  for (size_t k = 0; k < first.size(); ++k) EXPECT_EQ(again[k], first[k]) << "waypoint " << k;
}

TEST(FreePath, AnEndInCollisionHasNoPathAndIsAnsweredWithoutSampling) {
  const JointVector lower = JointVector::Constant(-3.0), upper = JointVector::Constant(3.0);
  const JointVector inside_wall = joints(0.0, 0.0, 0.0), free_end = joints(1.0, 0.0, 0.0);
  ASSERT_FALSE(free_of_wall(inside_wall));
  for (const auto& [a, b] : {std::pair{inside_wall, free_end}, std::pair{free_end, inside_wall}}) {
    int checks = 0;
    const auto counted = [&](const JointVector& q) {
      ++checks;
      return free_of_wall(q);
    };
    EXPECT_TRUE(free_joint_path(a, b, lower, upper, counted, 0.02, 5.0).empty());
    EXPECT_LE(checks, 2) << "the planner sampled for a path that cannot exist";
  }
}

// Where no path exists, the search gives up after its budget of questions, not of seconds: the same question
// is answered the same on a fast machine and a slow one. (A time limit made a planner test pass on one
// machine and fail on a faster one, where the search found, within the limit, a way it did not find on the
// other.)
TEST(FreePath, GivesUpAfterItsBudgetOfQuestions) {
  const JointVector lower = JointVector::Constant(-3.0), upper = JointVector::Constant(3.0);
  // b is shut in a box of joint space: every way to it crosses the box's wall.
  const JointVector a = joints(-1.0, 0.0, 0.0), b = joints(1.0, 0.0, 0.0);
  const auto boxed = [&](const JointVector& q) {
    const double r = (q - b).cwiseAbs().maxCoeff();
    return !(r > 0.2 && r < 0.5);
  };
  for (const long budget : {2000L, 20000L}) {
    long checks = 0;
    const auto counted = [&](const JointVector& q) {
      ++checks;
      return boxed(q);
    };
    EXPECT_TRUE(free_joint_path(a, b, lower, upper, counted, 0.02, budget).empty());
    EXPECT_GE(checks, budget) << "gave up before its budget";
    EXPECT_LE(checks, budget + budget / 10 + 200) << "went on past its budget";
  }
}

}  // namespace
}  // namespace weldtwin
