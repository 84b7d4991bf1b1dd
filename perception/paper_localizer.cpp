#include "perception/paper_localizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include <nanoflann.hpp>

// PCL's templates are compiled here from its headers rather than linked from its precompiled libraries: the
// segmentation library drags in the features library, whose loading cost every process ~0.05 s.
#define PCL_NO_PRECOMPILE
#include <pcl/common/centroid.h>
#include <pcl/common/common.h>
#include <pcl/console/print.h>
#include <pcl/filters/passthrough.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/sac_segmentation.h>

#include "perception/neighbour_grid.hpp"

namespace weldtwin {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// PCL's search interface answered by nanoflann, for the paper's ICP (PCL's own algorithm): the same
// neighbours as PCL's FLANN tree, which opens an OpenMP region and allocates for every single query
// (`weldtwin_bench --benchmark_filter=Nearest`). Not for use from several threads at once.
class NanoflannSearch : public pcl::search::KdTree<pcl::PointXYZ> {
 public:
  using Ptr = std::shared_ptr<NanoflannSearch>;
  NanoflannSearch() : pcl::search::KdTree<pcl::PointXYZ>(true) {}

  void setInputCloud(const PointCloudConstPtr& cloud, const pcl::IndicesConstPtr& indices = {}) override {
    input_ = cloud;
    indices_ = indices;
    data_.cloud = cloud.get();
    data_.indices = indices.get();
    index_ = std::make_unique<Index>(3, data_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    index_->buildIndex();
    ++generation_;
    lo_.setConstant(std::numeric_limits<double>::infinity());
    hi_ = -lo_;
    for (size_t i = 0; i < data_.kdtree_get_point_count(); ++i) {
      const Eigen::Vector3d q = (*cloud)[static_cast<size_t>(data_.original(static_cast<uint32_t>(i)))]
                                    .getVector3fMap()
                                    .cast<double>();
      lo_ = lo_.cwiseMin(q), hi_ = hi_.cwiseMax(q);
    }
  }

  /// ICP's correspondences: a neighbour farther than `bound_m` is rejected whichever it is, so a single
  /// nearest search from a point that far from the cloud's box answers with the first point (at its true
  /// distance, beyond the bound) without searching. Infinite (the default): every answer is the nearest.
  void set_bound(double bound_m) { bound_ = bound_m; }

  /// Whether every point lies beyond the bound from `p` (float rounding included): its box does.
  bool beyond_bound(const pcl::PointXYZ& p) const {
    if (!std::isfinite(bound_) || data_.kdtree_get_point_count() == 0) return false;
    const Eigen::Vector3d q = p.getVector3fMap().cast<double>();
    const double gap = (lo_ - q).cwiseMax(q - hi_).cwiseMax(0.0).norm();
    return gap > bound_ * (1.0 + 1e-6) + 1e-9;
  }

  /// The two nearest points (tree order, not the original cloud's) and their squared distances, as the tree
  /// computes them; returns how many there are (0-2).
  size_t nearest(const pcl::PointXYZ& p, size_t k, uint32_t* idx, float* d2) const {
    return data_.kdtree_get_point_count() == 0 ? 0 : index_->knnSearch(p.data, k, idx, d2);
  }
  /// The squared distance from `p` to tree point `i`, computed as the tree computes it.
  float squared_distance(const pcl::PointXYZ& p, uint32_t i) const {
    return index_->distance.evalMetric(p.data, i, 3);
  }
  int original(uint32_t i) const { return data_.original(i); }
  /// Counts the clouds set: what was found in an earlier one does not hold in this one.
  size_t generation() const { return generation_; }

  int nearestKSearch(const pcl::PointXYZ& p, int k, pcl::Indices& idx,
                     std::vector<float>& d2) const override {
    if (k == 1 && beyond_bound(p)) {
      idx.assign(1, data_.original(0));
      const Eigen::Vector3f first =
          (*input_)[static_cast<size_t>(idx[0])].getVector3fMap() - p.getVector3fMap();
      d2.assign(1, first.squaredNorm());
      return 1;
    }
    const size_t want = static_cast<size_t>(std::max(k, 0));
    std::vector<uint32_t>& found = knn_;
    found.resize(want);
    d2.resize(want);
    const size_t n =
        data_.kdtree_get_point_count() == 0 ? 0 : index_->knnSearch(p.data, want, found.data(), d2.data());
    idx.resize(n);
    d2.resize(n);
    for (size_t i = 0; i < n; ++i) idx[i] = data_.original(found[i]);
    return static_cast<int>(n);
  }

  int radiusSearch(const pcl::PointXYZ& p, double radius, pcl::Indices& idx, std::vector<float>& d2,
                   unsigned int max_nn = 0) const override {
    std::vector<std::pair<uint32_t, float>>& found = radius_;
    found.clear();
    if (data_.kdtree_get_point_count() > 0)
      index_->radiusSearch(p.data, static_cast<float>(radius * radius), found,
                           nanoflann::SearchParams(32, 0.0f, sorted_results_ || max_nn > 0));
    if (max_nn > 0 && found.size() > max_nn) found.resize(max_nn);
    idx.resize(found.size());
    d2.resize(found.size());
    for (size_t i = 0; i < found.size(); ++i)
      idx[i] = data_.original(found[i].first), d2[i] = found[i].second;
    return static_cast<int>(found.size());
  }

 private:
  struct Data {
    const Cloud* cloud = nullptr;
    const pcl::Indices* indices = nullptr;  // null: every point
    size_t kdtree_get_point_count() const { return indices ? indices->size() : cloud ? cloud->size() : 0; }
    int original(uint32_t i) const { return indices ? (*indices)[i] : static_cast<int>(i); }
    float kdtree_get_pt(size_t i, size_t d) const {
      return (*cloud)[static_cast<size_t>(original(static_cast<uint32_t>(i)))].data[d];
    }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Index =
      nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Data>, Data, 3, uint32_t>;
  Data data_;
  std::unique_ptr<Index> index_;
  Eigen::Vector3d lo_ = Eigen::Vector3d::Zero(), hi_ = Eigen::Vector3d::Zero();  ///< the cloud's box
  double bound_ = std::numeric_limits<double>::infinity();
  size_t generation_ = 0;
  mutable std::vector<uint32_t> knn_;  // answers in the making, kept for their memory
  mutable std::vector<std::pair<uint32_t, float>> radius_;
};

// ICP's correspondences, those of PCL's CorrespondenceEstimation (each source point's nearest target point,
// when within the distance: the same matches and distances), without searching again for a source point whose
// nearest cannot have changed since its last search. A search finds the two nearest, at d1 < d2; a point
// moved by m since is still nearest to the first while d1 + m < d2 - m, and has none within the distance
// while d1 - m is beyond it. (A tie, d1 = d2, is searched as PCL searches it, every time.) Late in ICP the
// source moves by micrometres a step: most points are not searched again.
class CachedCorrespondences
    : public pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ, float> {
 public:
  explicit CachedCorrespondences(std::shared_ptr<const NanoflannSearch> search)
      : search_(std::move(search)) {}

  void determineCorrespondences(pcl::Correspondences& correspondences, double max_distance) override {
    if (!initCompute()) return;
    if (tree_.get() != search_.get())
      throw std::logic_error("CachedCorrespondences: ICP searches another tree than this one's");
    if (generation_ != search_->generation() || cache_.size() != input_->size()) {
      cache_.assign(input_->size(), Entry());
      generation_ = search_->generation();
    }
    const double max_dist_sqr = max_distance * max_distance;
    constexpr double kSlack = 1e-6;  // m: far above the float rounding of the distances
    correspondences.resize(indices_->size());
    size_t valid = 0;
    pcl::Indices one(1);
    std::vector<float> one_d2(1);
    for (const auto& idx : *indices_) {
      const pcl::PointXYZ& p = (*input_)[static_cast<size_t>(idx)];
      Entry& e = cache_[static_cast<size_t>(idx)];
      int match = -1;
      float d2 = 0.0f;
      if (search_->beyond_bound(p)) continue;  // PCL's search would find nothing within the distance
      const double moved =
          e.valid ? (p.getVector3fMap() - Eigen::Map<const Eigen::Vector3f>(e.at)).cast<double>().norm()
                  : 0.0;
      bool found = false;
      if (e.valid && e.first_m - moved > max_distance + kSlack) {
        continue;  // none within the distance, as at the last search
      }
      if (e.valid && e.last_m - moved > kSlack) {
        // The nearest now, if nearer than the last search's farthest candidate is now at the least.
        float best = std::numeric_limits<float>::infinity(), tie = best;
        uint32_t best_i = 0;
        for (int k = 0; k < e.count; ++k) {
          const float d = search_->squared_distance(p, e.candidates[k]);
          if (d < best)
            tie = best, best = d, best_i = e.candidates[k];
          else if (d < tie)
            tie = d;
        }
        if (best < tie && std::sqrt(static_cast<double>(best)) + kSlack < e.last_m - moved) {
          match = search_->original(best_i), d2 = best, found = true;
        }
      }
      if (!found) {
        uint32_t near[kCandidates];
        float near_d2[kCandidates];
        const size_t n = search_->nearest(p, kCandidates, near, near_d2);
        if (n == 0) continue;
        if (n >= 2 && near_d2[0] == near_d2[1]) {  // a tie: PCL's own single search decides
          e.valid = false;
          search_->nearestKSearch(p, 1, one, one_d2);
          match = one[0];
          d2 = one_d2[0];
        } else {
          e.valid = true;
          e.at[0] = p.x, e.at[1] = p.y, e.at[2] = p.z;
          e.count = static_cast<int>(n);
          std::copy(near, near + n, e.candidates);
          e.first_m = std::sqrt(static_cast<double>(near_d2[0]));
          e.last_m = n == kCandidates ? std::sqrt(static_cast<double>(near_d2[n - 1]))
                                      : std::numeric_limits<double>::infinity();
          match = search_->original(near[0]);
          d2 = near_d2[0];
        }
      }
      if (d2 > max_dist_sqr) continue;
      pcl::Correspondence& c = correspondences[valid++];
      c.index_query = idx;
      c.index_match = match;
      c.distance = d2;
    }
    correspondences.resize(valid);
    deinitCompute();
  }

 private:
  static constexpr int kCandidates = 8;
  struct Entry {
    float at[3] = {0, 0, 0};           ///< where the source point was searched from
    uint32_t candidates[kCandidates];  ///< tree indices of its nearest then, nearest first
    int count = 0;
    double first_m = 0.0, last_m = 0.0;  ///< the nearest's and the last candidate's distance then
    bool valid = false;
  };
  std::shared_ptr<const NanoflannSearch> search_;
  std::vector<Entry> cache_;
  size_t generation_ = 0;
};

Cloud::Ptr without(const Cloud::Ptr& in, const pcl::PointIndices& drop) {
  std::vector<char> gone(in->size(), 0);
  for (int i : drop.indices) gone[static_cast<size_t>(i)] = 1;
  Cloud::Ptr out(new Cloud);
  for (size_t i = 0; i < in->size(); ++i)
    if (!gone[i]) out->push_back((*in)[i]);
  return out;
}

}  // namespace

PoseEstimate localize_paper(const std::vector<Vec3>& scan_base, const Mesh& mesh, const PaperSetting& s) {
  const auto t0 = std::chrono::steady_clock::now();
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  PoseEstimate out;
  auto finish = [&](const std::string& reason) {
    out.reason = reason;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };
  Cloud::Ptr cloud(new Cloud);
  for (const Vec3& p : scan_base)
    if (p.head<2>().norm() <= s.reach_radius_m)
      cloud->push_back(
          pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  // PassThrough, voxel grid, statistical outlier removal.
  Cloud::Ptr cropped(new Cloud), grid(new Cloud), clean(new Cloud);
  pcl::PassThrough<pcl::PointXYZ> pass;
  pass.setInputCloud(cloud);
  pass.setFilterFieldName("z");
  pass.setFilterLimits(static_cast<float>(s.z_min_m), static_cast<float>(s.z_max_m));
  pass.filter(*cropped);
  pcl::VoxelGrid<pcl::PointXYZ> voxel;
  voxel.setInputCloud(cropped);
  const float leaf = static_cast<float>(s.voxel_m);
  voxel.setLeafSize(leaf, leaf, leaf);
  voxel.filter(*grid);
  if (grid->size() < 100) return finish("no points in the working volume");
  // Statistical outlier removal: PCL's steps, the neighbours from a grid (1.8x PCL's filter, same points).
  std::vector<Eigen::Vector3f> grid_points;
  grid_points.reserve(grid->size());
  for (const pcl::PointXYZ& p : *grid) grid_points.push_back(p.getVector3fMap());
  for (int i : statistical_inliers(grid_points, s.outlier_neighbours, s.outlier_stddev))
    clean->push_back((*grid)[static_cast<size_t>(i)]);

  // Cascaded RANSAC: the table (the biggest horizontal plane), then planes above the part's height.
  double model_height = 0.0, min_z = 1e9;
  for (const Vec3& v : mesh.vertices) min_z = std::min(min_z, v.z());
  for (const Vec3& v : mesh.vertices) model_height = std::max(model_height, v.z() - min_z);
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(static_cast<float>(deg2rad(10.0)));
  seg.setDistanceThreshold(static_cast<float>(s.plane_threshold_m));
  seg.setMaxIterations(500);
  seg.setInputCloud(clean);
  pcl::PointIndices table;
  pcl::ModelCoefficients coeff;
  seg.segment(table, coeff);
  if (table.indices.size() < 100) return finish("no table plane in the scan");
  Eigen::Vector4d plane(coeff.values[0], coeff.values[1], coeff.values[2], coeff.values[3]);
  if (plane[2] < 0) plane = -plane;
  out.table_plane = plane;
  Cloud::Ptr objects(new Cloud);
  const Cloud::Ptr off_table = without(clean, table);  // kept alive: a range-for over *temporary would dangle
  for (const auto& p : *off_table)
    if (plane.head<3>().dot(Vec3(p.x, p.y, p.z)) + plane[3] > s.plane_threshold_m) objects->push_back(p);
  for (int k = 0; k < 2 && objects->size() > 100; ++k) {
    pcl::PointIndices in;
    seg.setInputCloud(objects);
    seg.segment(in, coeff);
    if (in.indices.size() < 100 || -coeff.values[3] / coeff.values[2] < model_height + 0.005) break;
    objects = without(objects, in);
  }
  // Euclidean clusters (PCL's, on a grid: the same clusters in the same order): the one whose size is closest
  // to the model's.
  std::vector<Eigen::Vector3f> object_points;
  object_points.reserve(objects->size());
  for (const pcl::PointXYZ& p : *objects) object_points.push_back(p.getVector3fMap());
  std::vector<pcl::PointIndices> clusters;
  for (std::vector<int>& c : euclidean_clusters(object_points, static_cast<float>(s.cluster_tolerance_m), 50,
                                                std::numeric_limits<int>::max())) {
    clusters.emplace_back();
    clusters.back().indices.assign(c.begin(), c.end());
  }
  if (clusters.empty()) return finish("nothing stands on the table");
  double model_size = 0.0;
  for (const Vec3& v : mesh.vertices) model_size = std::max(model_size, v.head<2>().norm());
  const pcl::PointIndices* chosen = nullptr;
  double chosen_gap = 1e9;
  for (const pcl::PointIndices& c : clusters) {
    Eigen::Vector4f lo, hi;
    pcl::getMinMax3D(*objects, c, lo, hi);
    const double size = 0.5 * (hi - lo).head<2>().norm();
    if (std::abs(size - model_size) < chosen_gap) chosen_gap = std::abs(size - model_size), chosen = &c;
  }
  Cloud::Ptr target(new Cloud);
  pcl::copyPointCloud(*objects, *chosen, *target);

  // Model samples over the whole mesh (the paper samples every face), centroid guess, point-to-point ICP.
  Mesh rest = mesh;
  for (Vec3& v : rest.vertices) v.z() -= min_z;
  const SurfaceSamples samples = sample_surface(rest, s.voxel_m, -2.0);
  Cloud::Ptr source(new Cloud);
  for (const Vec3& p : samples.points)
    source->push_back(
        pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  Eigen::Vector4f c_model, c_scan;
  pcl::compute3DCentroid(*source, c_model);
  pcl::compute3DCentroid(*target, c_scan);
  Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
  guess.block<3, 1>(0, 3) = (c_scan - c_model).head<3>();
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(source);
  const auto search = std::make_shared<NanoflannSearch>();
  search->set_bound(s.icp_max_distance_m);  // PCL's correspondences take no neighbour beyond it
  icp.setSearchMethodTarget(search);
  if (s.icp_reuse_neighbours)
    icp.setCorrespondenceEstimation(std::make_shared<CachedCorrespondences>(search));
  icp.setInputTarget(target);
  icp.setMaximumIterations(s.icp_iterations);
  icp.setMaxCorrespondenceDistance(s.icp_max_distance_m);
  icp.setTransformationEpsilon(1e-10);
  Cloud aligned;
  icp.align(aligned, guess);
  const Eigen::Matrix4d M = icp.getFinalTransformation().cast<double>();
  Iso3 T_base_rest;
  T_base_rest.matrix() = M;
  out.T_base_part = orthonormalized(T_base_rest * make_transform(Vec3(0, 0, -min_z), Mat3::Identity()));
  out.converged = icp.hasConverged();
  search->set_bound(std::numeric_limits<double>::infinity());  // the fitness takes every nearest neighbour
  out.rmse_m = std::sqrt(icp.getFitnessScore());
  out.object_points = static_cast<int>(target->size());
  out.found = true;
  return finish("");
}

}  // namespace weldtwin
