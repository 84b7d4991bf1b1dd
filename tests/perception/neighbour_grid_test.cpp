// The grid's statistical outlier filter against PCL's own (pcl_filters, PCL's FLANN tree) on the same clouds:
// the same points kept, and the filter does filter.
#include "perception/neighbour_grid.hpp"

#include <gtest/gtest.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_types.h>

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

}  // namespace
}  // namespace weldtwin
