// Nearest neighbours among fixed points: nanoflann's kd-tree. A query is a plain function call (PCL's FLANN
// wrapper opens an OpenMP region and allocates for every single-point query, which made those queries most
// of a localization's time).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <nanoflann.hpp>

#include "core/geometry.hpp"

namespace weldtwin {

class PointTree {
 public:
  explicit PointTree(std::vector<Vec3> points = {}) : data_(std::make_unique<Data>()) {
    data_->pts = std::move(points);
    index_ = std::make_unique<Index>(3, *data_, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize));
  }
  /// The k nearest points, nearest first: indices and squared distances. Returns how many.
  size_t knn(const Vec3& q, size_t k, std::vector<uint32_t>& idx, std::vector<double>& d2) const {
    idx.resize(k);
    d2.resize(k);
    const size_t n = data_->pts.empty() ? 0 : index_->knnSearch(q.data(), k, idx.data(), d2.data());
    idx.resize(n);
    d2.resize(n);
    return n;
  }
  /// The nearest point's index (-1 if there are none) and its squared distance.
  int nearest(const Vec3& q, double& d2) const {
    if (data_->pts.empty()) return -1;
    uint32_t i = 0;
    index_->knnSearch(q.data(), 1, &i, &d2);
    return static_cast<int>(i);
  }
  /// The same within `max_m` only: -1 when no point is that near (a search that stops early, far cheaper
  /// for questions far from every point). When one is, the answer is nearest()'s, to the tie.
  int nearest_within(const Vec3& q, double max_m, double& d2) const {
    if (data_->pts.empty()) return -1;
    Within within{max_m * max_m};
    index_->findNeighbors(within, q.data(), nanoflann::SearchParams());
    d2 = within.best;
    return within.index;
  }
  /// nearest()'s answer, to the tie, sought first within `likely_m` (where the nearest point usually is: the
  /// search prunes more) and in the whole tree only when none is that near.
  int nearest_likely_within(const Vec3& q, double likely_m, double& d2) const {
    const int k = nearest_within(q, likely_m, d2);
    return k >= 0 ? k : nearest(q, d2);
  }
  const std::vector<Vec3>& points() const { return data_->pts; }

 private:
  static constexpr size_t kLeafSize = 10;  ///< points per leaf (10, 20 and 32 measured alike)
  struct Data {
    std::vector<Vec3> pts;
    size_t kdtree_get_point_count() const { return pts.size(); }
    double kdtree_get_pt(size_t i, size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  // nanoflann's result-set interface for one nearest point, searched only within a radius.
  struct Within {
    double best;  ///< squared distance: the radius, then the best so far
    int index = -1;
    size_t size() const { return index >= 0 ? 1 : 0; }
    bool full() const { return true; }
    bool addPoint(double d2, uint32_t i) {
      if (d2 < best) {
        best = d2;
        index = static_cast<int>(i);
      }
      return true;
    }
    double worstDist() const { return best; }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Data>, Data, 3>;
  std::unique_ptr<Data> data_;  // the index refers to it: it must not move
  std::unique_ptr<Index> index_;
};

}  // namespace weldtwin
