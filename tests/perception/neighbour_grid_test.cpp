// The grid's statistical outlier filter against PCL's own (pcl_filters, PCL's FLANN tree) on the same clouds:
// the same points kept, and the filter does filter; the mean distances against a brute-force search. The
// grid's Euclidean clusters against PCL's, cluster for cluster in the same order.
#include "perception/neighbour_grid.hpp"

#include <gtest/gtest.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <utility>

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

// Blobs of random sizes (several of the same size, for the order of PCL's unstable sort), chains of points
// 0.99 tolerances apart (one cluster each) and 1.01 apart (lone points), the plates and lone points of the
// scene above, all shuffled.
TEST(NeighbourGridTest, EuclideanClustersArePclsInPclsOrder) {
  for (unsigned seed : {5u, 6u}) {
    size_t lone_from = 0;
    std::vector<Eigen::Vector3f> pts = scene(seed, lone_from);
    pts.erase(pts.begin() + static_cast<long>(lone_from) - 1);  // the NaN: PCL's search wants finite points
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    const float tol = 0.008f;
    for (int b = 0; b < 40; ++b) {
      const Eigen::Vector3f c(0.5f + 0.05f * static_cast<float>(b % 8),
                              -0.5f + 0.05f * static_cast<float>(b / 8), 0.1f);
      const int size = b < 12 ? 60 : 20 + static_cast<int>(80 * unit(rng));  // twelve of 60
      for (int i = 0; i < size; ++i)
        pts.push_back(c + 0.01f * Eigen::Vector3f(unit(rng), unit(rng), unit(rng)));
    }
    for (int i = 0; i < 70; ++i) {
      pts.emplace_back(-0.6f + 0.99f * tol * static_cast<float>(i), 0.4f, 0.2f);
      pts.emplace_back(-0.6f + 1.01f * tol * static_cast<float>(i), 0.45f, 0.2f);
    }
    std::shuffle(pts.begin(), pts.end(), rng);
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    for (const Eigen::Vector3f& p : pts) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    for (const auto& [t, min_size] :
         {std::pair{tol, size_t{1}}, std::pair{tol, size_t{50}}, std::pair{0.02f, size_t{50}}}) {
      pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
      ec.setClusterTolerance(t);
      ec.setMinClusterSize(static_cast<int>(min_size));
      ec.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
      ec.setInputCloud(cloud);
      std::vector<pcl::PointIndices> expected;
      ec.extract(expected);
      const std::vector<std::vector<int>> clusters = euclidean_clusters(pts, t, min_size, size_t{1} << 31);
      ASSERT_EQ(clusters.size(), expected.size()) << "seed " << seed << ", tolerance " << t;
      for (size_t c = 0; c < clusters.size(); ++c)
        ASSERT_EQ(clusters[c], std::vector<int>(expected[c].indices.begin(), expected[c].indices.end()))
            << "cluster " << c << ", seed " << seed << ", tolerance " << t;
      if (min_size == 1) {
        EXPECT_GT(clusters.size(), 150u);  // the lone points count
      }
    }
  }
}

}  // namespace
}  // namespace weldtwin
