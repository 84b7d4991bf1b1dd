// Nearest-neighbour queries as the localizer makes them: one point at a time against ~25,000 samples of a
// part's surface. PCL's KdTreeFLANN (FLANN behind it) against nanoflann, both exact, on the same points.
#include <benchmark/benchmark.h>

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <algorithm>
#include <memory>
#include <nanoflann.hpp>
#include <random>
#include <vector>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/geometry.hpp"
#include "core/part_spec.hpp"
#include "perception/localizer.hpp"
#include "perception/mesh_io.hpp"
#include "perception/neighbour_grid.hpp"
#include "perception/paper_localizer.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/sweep_sim.hpp"

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

// The paper's statistical outlier filter (k = 30, 1 sd) on the cloud its pipeline gives it: the default
// cell's sweep, assembled, cropped to the working volume and voxel-filtered at 3 mm. PCL's filter (a FLANN
// tree query per point) against the same steps on weldtwin's grid; both keep the same points
// (neighbour_grid_test).
const pcl::PointCloud<pcl::PointXYZ>::Ptr& voxel_scan() {
  static const pcl::PointCloud<pcl::PointXYZ>::Ptr grid = [] {
    using namespace weldtwin;
    const CellSpec spec = CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/default.yaml");
    const PartSpec part = PartSpec::load(spec.part_spec);
    const RobotModel robot = load_cell_robot(spec);
    const MujocoWorld world(spec, part, robot, make_layout(spec, part, std::nullopt));
    const SweepResult sweep =
        simulate_sweep(world, robot, SweepProgram::load(spec.sweep_program, robot), LidarSetting());
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    for (const Vec3& p : assemble_scan(sweep.log, robot).points_base)
      if (p.z() > -0.05 && p.z() < 0.5 && p.head<2>().norm() < 1.2)
        cloud->push_back(
            pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
    pcl::VoxelGrid<pcl::PointXYZ> voxel;
    voxel.setInputCloud(cloud);
    voxel.setLeafSize(0.003f, 0.003f, 0.003f);
    voxel.filter(*out);
    return out;
  }();
  return grid;
}

void BM_OutlierFilterPcl(benchmark::State& state) {
  const auto& grid = voxel_scan();
  for (auto _ : state) {
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
    sor.setInputCloud(grid);
    sor.setMeanK(30);
    sor.setStddevMulThresh(1.0);
    pcl::Indices kept;
    sor.filter(kept);
    benchmark::DoNotOptimize(kept.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * grid->size()));
}
BENCHMARK(BM_OutlierFilterPcl)->Unit(benchmark::kMillisecond);

void BM_OutlierFilterGrid(benchmark::State& state) {
  const auto& grid = voxel_scan();
  std::vector<Eigen::Vector3f> pts;
  for (const auto& p : *grid) pts.push_back(p.getVector3fMap());
  for (auto _ : state) {
    const std::vector<int> kept = weldtwin::statistical_inliers(pts, 30, 1.0);
    benchmark::DoNotOptimize(kept.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * grid->size()));
}
BENCHMARK(BM_OutlierFilterGrid)->Unit(benchmark::kMillisecond);

// The paper's Euclidean clusters (8 mm, at least 50 points) on what stands on the table in that cloud: the
// points more than 4 mm above the table (the median height). PCL's extraction (a radius search per point,
// through PCL's FLANN tree) against weldtwin's grid and union-find; both give the same clusters in the same
// order (neighbour_grid_test).
const std::vector<Eigen::Vector3f>& objects_above_table() {
  static const std::vector<Eigen::Vector3f> objects = [] {
    std::vector<float> z;
    for (const auto& p : *voxel_scan()) z.push_back(p.z);
    std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
    const float table = z[z.size() / 2];
    std::vector<Eigen::Vector3f> out;
    for (const auto& p : *voxel_scan())
      if (p.z > table + 0.004f) out.push_back(p.getVector3fMap());
    return out;
  }();
  return objects;
}

void BM_EuclideanClustersPcl(benchmark::State& state) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  for (const Eigen::Vector3f& p : objects_above_table()) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  for (auto _ : state) {
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
    ec.setClusterTolerance(0.008);
    ec.setMinClusterSize(50);
    ec.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    ec.setInputCloud(cloud);
    std::vector<pcl::PointIndices> clusters;
    ec.extract(clusters);
    benchmark::DoNotOptimize(clusters.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud->size()));
}
BENCHMARK(BM_EuclideanClustersPcl)->Unit(benchmark::kMillisecond);

void BM_EuclideanClustersGrid(benchmark::State& state) {
  const std::vector<Eigen::Vector3f>& pts = objects_above_table();
  for (auto _ : state) {
    const auto clusters = weldtwin::euclidean_clusters(pts, 0.008f, 50, size_t{1} << 31);
    benchmark::DoNotOptimize(clusters.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * pts.size()));
}
BENCHMARK(BM_EuclideanClustersGrid)->Unit(benchmark::kMillisecond);

// The paper's whole pipeline on twin scans of a tube and of a tee (seeds whose clusters are ~340 and ~12,600
// points; ICP is most of the tee's time), with ICP's reused neighbours (Arg 1) and with PCL's own
// correspondence search on the same tree (Arg 0): the same pose (paper_localizer_test).
struct PaperScan {
  std::vector<weldtwin::Vec3> points, viewpoints;
  weldtwin::Mesh mesh;
  std::vector<weldtwin::Vec3> seam_points;
};

const PaperScan& paper_scan(int which) {
  static const std::vector<PaperScan> scans = [] {
    using namespace weldtwin;
    std::vector<PaperScan> out;
    for (const auto& [name, seed] : {std::pair{"default", 3}, {"tube_tee", 4}}) {
      const CellSpec spec =
          CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/" + name + ".yaml");
      const PartSpec part = PartSpec::load(spec.part_spec);
      const RobotModel robot = load_cell_robot(spec);
      const MujocoWorld world(spec, part, robot, make_layout(spec, part, seed));
      LidarSetting lidar;
      lidar.seed = static_cast<uint64_t>(seed);
      const SweepResult sweep =
          simulate_sweep(world, robot, SweepProgram::load(spec.sweep_program, robot), lidar);
      const AssembledCloud cloud = assemble_scan(sweep.log, robot);
      out.push_back(
          {cloud.points_base, cloud.viewpoints_base, load_mesh(part.mesh_path), part.seam_points(0.001)});
    }
    return out;
  }();
  return scans[static_cast<size_t>(which)];
}

void BM_PaperPipeline(benchmark::State& state) {
  const PaperScan& scan = paper_scan(static_cast<int>(state.range(0)));
  weldtwin::PaperSetting setting;
  setting.icp_reuse_neighbours = state.range(1) != 0;
  for (auto _ : state) {
    const weldtwin::PoseEstimate pose = weldtwin::localize_paper(scan.points, scan.mesh, setting);
    benchmark::DoNotOptimize(pose.rmse_m);
  }
}
BENCHMARK(BM_PaperPipeline)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"tee", "reuse"})
    ->Unit(benchmark::kMillisecond);

// Our localizer on the same scans (with their viewpoints, as the randomized benchmark localizes), given the
// mesh (Arg 0: the part is prepared anew each time) or a part prepared once (Arg 1: its nearest-sample grid
// filled by the iterations before, as by a bench worker's earlier trials): the same pose (localizer_test).
void BM_OursPipeline(benchmark::State& state) {
  const PaperScan& scan = paper_scan(static_cast<int>(state.range(0)));
  weldtwin::LocalizeSetting setting;
  setting.threads = 1;
  const weldtwin::PreparedPart part(scan.mesh, setting);
  for (auto _ : state) {
    const weldtwin::PoseEstimate pose =
        state.range(1) != 0
            ? weldtwin::localize(scan.points, part, setting, scan.seam_points, scan.viewpoints)
            : weldtwin::localize(scan.points, scan.mesh, setting, scan.seam_points, scan.viewpoints);
    benchmark::DoNotOptimize(pose.rmse_m);
  }
}
BENCHMARK(BM_OursPipeline)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"tee", "prepared"})
    ->Unit(benchmark::kMillisecond);
