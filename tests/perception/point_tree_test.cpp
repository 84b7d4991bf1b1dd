// The kd-tree's radius-limited nearest point must be its nearest point whenever that is within the radius
// (the same index, ties included), and nothing when it is not; sought first within a likely radius, it is
// the nearest point whether or not that is within the radius.
#include "perception/localize/point_tree.hpp"

#include <gtest/gtest.h>

#include <random>

namespace weldtwin {
namespace {

TEST(PointTree, NearestWithinIsNearestOrNothing) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 0.1), wide(-0.05, 0.15), reach(0.0, 0.02);
  std::vector<Vec3> pts;
  for (int i = 0; i < 3000; ++i) pts.emplace_back(u(rng), u(rng), 0.002 * std::round(u(rng) / 0.002));
  for (int i = 0; i < 200; ++i) pts.push_back(pts[static_cast<size_t>(i)]);  // exact ties
  const PointTree tree(pts);
  int inside = 0, beyond = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 q(wide(rng), wide(rng), wide(rng));
    const double r = reach(rng);
    double d_all = 0.0, d_within = -1.0;
    const int all = tree.nearest(q, d_all);
    const int within = tree.nearest_within(q, r, d_within);
    double d_likely = -1.0;
    ASSERT_EQ(tree.nearest_likely_within(q, r, d_likely), all) << q.transpose() << " likely within " << r;
    ASSERT_EQ(d_likely, d_all);
    if (d_all < r * r) {
      ++inside;
      ASSERT_EQ(within, all) << q.transpose() << " within " << r;
      ASSERT_EQ(d_within, d_all);
    } else {
      ++beyond;
      ASSERT_EQ(within, -1) << q.transpose() << " within " << r;
    }
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GT(beyond, 1000);
  double d = 0.0;
  EXPECT_EQ(PointTree().nearest_within(Vec3::Zero(), 1.0, d), -1);
}

}  // namespace
}  // namespace weldtwin
