// Nearest-neighbour queries as the localizer makes them: one point at a time against ~25,000 samples of a
// part's surface. PCL's KdTreeFLANN (FLANN behind it) against nanoflann, both exact, on the same points.
#include <benchmark/benchmark.h>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <memory>
#include <nanoflann.hpp>
#include <random>
#include <vector>

#include "core/geometry.hpp"

namespace {

// Samples every 2 mm on the faces of a 160 x 160 x 8 mm plate and a 50 x 50 x 100 mm tube standing on it.
std::vector<weldtwin::Vec3> part_samples() {
  std::vector<weldtwin::Vec3> pts;
  for (double x = -0.08; x <= 0.08; x += 0.002)
    for (double y = -0.08; y <= 0.08; y += 0.002) pts.emplace_back(x, y, 0.008);
  for (double z = 0.008; z <= 0.108; z += 0.002)
    for (double t = -0.025; t <= 0.025; t += 0.002)
      for (const auto& [x, y] : {std::pair{t, -0.025}, {t, 0.025}, {-0.025, t}, {0.025, t}})
        pts.emplace_back(x, y, z);
  return pts;
}

std::vector<weldtwin::Vec3> queries(size_t n) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> xy(-0.09, 0.09), z(0.0, 0.12);
  std::vector<weldtwin::Vec3> q;
  for (size_t i = 0; i < n; ++i) q.emplace_back(xy(rng), xy(rng), z(rng));
  return q;
}

void BM_NearestPclFlann(benchmark::State& state) {
  const std::vector<weldtwin::Vec3> pts = part_samples(), q = queries(4096);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : pts)
    cloud->push_back(
        pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  std::vector<int> idx(1);
  std::vector<float> d2(1);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = q[i++ % q.size()];
    tree.nearestKSearch(
        pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())), 1,
        idx, d2);
    benchmark::DoNotOptimize(idx[0]);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_NearestPclFlann);

struct Points {
  std::vector<weldtwin::Vec3> pts;
  size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(size_t i, size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

void BM_NearestNanoflann(benchmark::State& state) {
  const Points data{part_samples()};
  const std::vector<weldtwin::Vec3> q = queries(4096);
  const nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Points>, Points, 3> tree(
      3, data, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  uint32_t idx = 0;
  double d2 = 0.0;
  size_t i = 0;
  for (auto _ : state) {
    tree.knnSearch(q[i++ % q.size()].data(), 1, &idx, &d2);
    benchmark::DoNotOptimize(idx);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_NearestNanoflann);

}  // namespace
