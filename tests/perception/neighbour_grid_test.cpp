// The grid's statistical outlier filter against PCL's own (pcl_filters, PCL's FLANN tree) on the same clouds:
// the same points kept, and the filter does filter; the mean distances against a brute-force search.
#include "perception/neighbour_grid.hpp"

#include <gtest/gtest.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace weldtwin {
namespace {

// A voxel-filtered scan in miniature: two plates sampled 3 mm apart (one standing), with noise, a sparse row
// far off, lone points scattered over the box, and a NaN.
std::vector<Eigen::Vector3f> scene(unsigned seed, size_t& lone_from) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.0007f);
  std::uniform_real_distribution<float> box(-0.3f, 0.3f);
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 120; ++i)
    for (int j = 0; j < 80; ++j) {
      pts.emplace_back(-0.2f + 0.003f * i, -0.1f + 0.003f * j, noise(rng));
      if (i < 40) pts.emplace_back(0.1f + 0.003f * i, 0.15f + noise(rng), 0.002f * j + noise(rng));
    }
  pts.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  lone_from = pts.size();
  for (int i = 0; i < 30; ++i) pts.emplace_back(0.8f + 0.02f * i, 0.5f, 0.3f);  // the neighbours are far
  for (int i = 0; i < 150; ++i) pts.emplace_back(box(rng), box(rng), 0.02f + std::abs(box(rng)));
  return pts;
}

TEST(NeighbourGridTest, StatisticalInliersAreThePointsPclKeeps) {
  for (unsigned seed : {1u, 2u, 3u}) {
    size_t lone_from = 0;
    const std::vector<Eigen::Vector3f> pts = scene(seed, lone_from);
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    for (const Eigen::Vector3f& p : pts) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    cloud->is_dense = false;
    for (const auto& [k, mul] : {std::pair{30, 1.0}, std::pair{10, 2.0}, std::pair{3, 0.5}}) {
      pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
      sor.setInputCloud(cloud);
      sor.setMeanK(k);
      sor.setStddevMulThresh(mul);
      pcl::Indices pcl_kept;
      sor.filter(pcl_kept);
      const std::vector<int> kept = statistical_inliers(pts, k, mul);
      EXPECT_EQ(kept, std::vector<int>(pcl_kept.begin(), pcl_kept.end())) << "seed " << seed << ", k = " << k;
      size_t plates = 0, lone = 0;
      for (int i : kept) (static_cast<size_t>(i) < lone_from ? plates : lone) += 1;
      EXPECT_LT(lone, 90u);                   // most lone points go
      EXPECT_GT(plates, lone_from * 8 / 10);  // the plates stay
    }
  }
}

// Each point's mean distance to its k nearest, by sorting its distances to all points and summing the square
// roots of the k after itself in order, as PCL does. The grid sums them in another order: equal to the last
// bit of the float but for a rare rounding tie.
TEST(NeighbourGridTest, MeanDistancesAreTheBruteForceOnes) {
  size_t lone_from = 0;
  const std::vector<Eigen::Vector3f> pts = scene(4, lone_from);
  for (int k : {30, 7, 1}) {
    const std::vector<float> mean = mean_neighbour_distances(pts, k);
    ASSERT_EQ(mean.size(), pts.size());
    EXPECT_EQ(mean[lone_from - 1], 0.0f);  // the NaN point
    size_t exact = 0, finite = 0;
    for (size_t i = 0; i < pts.size(); i += i < lone_from ? 3 : 1) {  // every third plate point, all others
      if (!pts[i].allFinite()) {
        EXPECT_EQ(mean[i], 0.0f);
        continue;
      }
      std::vector<float> d2;
      for (const Eigen::Vector3f& q : pts) {
        const float ex = q.x() - pts[i].x(), ey = q.y() - pts[i].y(), ez = q.z() - pts[i].z();
        if (q.allFinite()) d2.push_back(ex * ex + ey * ey + ez * ez);  // in the order of PCL's search
      }
      std::nth_element(d2.begin(), d2.begin() + k, d2.end());
      std::sort(d2.begin(), d2.begin() + k);
      double sum = 0.0;
      for (int j = 1; j <= k; ++j) sum += std::sqrt(static_cast<double>(d2[static_cast<size_t>(j)]));
      const float want = static_cast<float>(sum / k);
      ASSERT_NEAR(mean[i], want, 1.5f * std::abs(std::nextafter(want, 1.0f) - want))
          << "point " << i << ", k " << k;
      exact += mean[i] == want;
      ++finite;
    }
    EXPECT_GE(exact, finite - finite / 1000) << "k = " << k;
  }
}

}  // namespace
}  // namespace weldtwin
