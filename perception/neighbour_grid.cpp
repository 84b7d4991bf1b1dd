#include "perception/neighbour_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <nanoflann.hpp>

namespace weldtwin {
namespace {

struct Points {
  const std::vector<Eigen::Vector3f>& pts;
  size_t kdtree_get_point_count() const { return pts.size(); }
  float kdtree_get_pt(size_t i, size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using Tree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Points>, Points, 3, uint32_t>;

// The `want` smallest of a[0, m) (m >= want >= 1): the largest of them and the sum of their square roots,
// taken in double as PCL takes them. Quickselect with branch-free three-way partitions, the first about
// `pivot`, each into the two buffers (of m floats) the current part does not occupy.
struct Smallest {
  float kth;
  double root_sum;
};
Smallest smallest(float* a, size_t m, size_t want, float pivot, float* s1, float* s2) {
  float* buf[3] = {a, s1, s2};
  int cur = 0;
  double sum = 0.0;
  for (;;) {
    const float* src = buf[cur];
    float* below = buf[(cur + 1) % 3];
    float* above = buf[(cur + 2) % 3];
    size_t nb = 0, na = 0;
    for (size_t j = 0; j < m; ++j) {
      const float x = src[j];
      below[nb] = x;
      above[na] = x;
      nb += x < pivot;
      na += x > pivot;
    }
    const size_t equal = m - nb - na;
    if (nb >= want) {
      cur = (cur + 1) % 3, m = nb;
    } else {
      for (size_t j = 0; j < nb; ++j) sum += std::sqrt(static_cast<double>(below[j]));
      if (nb + equal >= want) {
        sum += static_cast<double>(want - nb) * std::sqrt(static_cast<double>(pivot));
        return {pivot, sum};
      }
      sum += static_cast<double>(equal) * std::sqrt(static_cast<double>(pivot));
      want -= nb + equal;
      cur = (cur + 2) % 3, m = na;
    }
    // The median of three of the part left (m >= want >= 1 holds).
    const float* p = buf[cur];
    const float x = p[0], y = p[m / 2], z = p[m - 1];
    pivot = std::max(std::min(x, y), std::min(std::max(x, y), z));
  }
}

}  // namespace

std::vector<float> mean_neighbour_distances(const std::vector<Eigen::Vector3f>& points, int mean_k) {
  std::vector<uint32_t> finite;
  std::vector<Eigen::Vector3f> pts;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].allFinite()) finite.push_back(static_cast<uint32_t>(i)), pts.push_back(points[i]);
  std::vector<float> mean_distance(points.size(), 0.0f);
  if (!pts.empty() && mean_k > 0) {
    const Points data{pts};
    const Tree tree(3, data, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    const size_t want =
        std::min(static_cast<size_t>(mean_k) + 1, pts.size());  // the first is the point itself
    std::vector<uint32_t> idx(want);
    std::vector<float> d2(want);
    auto mean_of = [&](const float* nearest_first) {  // the first, the point itself, is left out as PCL does
      double sum = 0.0;
      for (size_t k = 1; k < want; ++k) sum += std::sqrt(static_cast<double>(nearest_first[k]));
      return static_cast<float>(sum / mean_k);
    };

    // The cell: within it nine points in ten have their neighbours (from a thousand of them).
    std::vector<float> kth;
    for (size_t i = 0; i < pts.size(); i += std::max<size_t>(1, pts.size() / 1000)) {
      tree.knnSearch(pts[i].data(), want, idx.data(), d2.data());
      kth.push_back(std::sqrt(d2[want - 1]));
    }
    std::nth_element(kth.begin(), kth.begin() + static_cast<long>(kth.size() * 9 / 10), kth.end());
    float cell = std::max(kth[kth.size() * 9 / 10], 1e-5f);
    Eigen::Vector3f lo = pts.front(), hi = pts.front();
    for (const Eigen::Vector3f& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    long n[3];
    for (;;) {
      for (int a = 0; a < 3; ++a) n[a] = static_cast<long>(std::floor((hi[a] - lo[a]) / cell)) + 1;
      if (static_cast<double>(n[0]) * static_cast<double>(n[1]) * static_cast<double>(n[2]) <= 16e6) break;
      cell *= 1.5f;
    }
    auto cell_index = [&](const Eigen::Vector3f& p, long c[3]) {
      for (int a = 0; a < 3; ++a) c[a] = std::min(n[a] - 1, static_cast<long>((p[a] - lo[a]) / cell));
      return static_cast<size_t>((c[2] * n[1] + c[1]) * n[0] + c[0]);
    };
    // Points sorted by cell (counting sort).
    const size_t cells = static_cast<size_t>(n[0] * n[1] * n[2]);
    std::vector<uint32_t> start(cells + 1, 0), of(pts.size());
    long c[3];
    for (size_t i = 0; i < pts.size(); ++i)
      ++start[(of[i] = static_cast<uint32_t>(cell_index(pts[i], c))) + 1];
    for (size_t k = 0; k < cells; ++k) start[k + 1] += start[k];
    std::vector<uint32_t> order(pts.size()), fill(start.begin(), start.end() - 1);
    for (size_t i = 0; i < pts.size(); ++i) order[fill[of[i]]++] = static_cast<uint32_t>(i);

    std::vector<float> bx, by, bz, dist, near, s1, s2;
    for (size_t o = 0; o < order.size();) {
      // The points of this cell, and every point of the block of cells around it.
      const size_t first = o, here = of[order[o]];
      while (o < order.size() && of[order[o]] == here) ++o;
      cell_index(pts[order[first]], c);
      bx.clear(), by.clear(), bz.clear();
      for (long z = std::max(0L, c[2] - 1); z <= std::min(n[2] - 1, c[2] + 1); ++z)
        for (long y = std::max(0L, c[1] - 1); y <= std::min(n[1] - 1, c[1] + 1); ++y) {
          const size_t row = static_cast<size_t>((z * n[1] + y) * n[0]);
          for (uint32_t k = start[row + static_cast<size_t>(std::max(0L, c[0] - 1))],
                        end = start[row + static_cast<size_t>(std::min(n[0] - 1, c[0] + 1)) + 1];
               k < end; ++k) {
            const Eigen::Vector3f& p = pts[order[k]];
            bx.push_back(p.x()), by.push_back(p.y()), bz.push_back(p.z());
          }
        }
      dist.resize(bx.size());
      near.resize(bx.size());
      s1.resize(bx.size());
      s2.resize(bx.size());
      float last_kth = -1.0f;  // squared
      for (size_t q = first; q < o; ++q) {
        const Eigen::Vector3f& p = pts[order[q]];
        // Everything nearer than the block's nearest face is in it (a side at the grid's edge has nothing
        // beyond).
        float reach = std::numeric_limits<float>::infinity();
        for (int a = 0; a < 3; ++a) {
          if (c[a] > 1) reach = std::min(reach, p[a] - (lo[a] + static_cast<float>(c[a] - 1) * cell));
          if (c[a] + 2 < n[a]) reach = std::min(reach, lo[a] + static_cast<float>(c[a] + 2) * cell - p[a]);
        }
        for (size_t j = 0; j < bx.size(); ++j) {
          const float ex = bx[j] - p.x(), ey = by[j] - p.y(), ez = bz[j] - p.z();
          dist[j] = ex * ex + ey * ey + ez * ez;
        }
        // Neighbouring points have about the same k-th distance: select among the distances below a guess
        // from the last one when there are enough of them, else among all; the last k-th the first pivot.
        float* d = dist.data();
        size_t m = dist.size();
        if (last_kth >= 0.0f) {
          const float guess = 1.5f * last_kth;
          size_t below = 0;
          for (size_t j = 0; j < dist.size(); ++j) {
            near[below] = dist[j];
            below += dist[j] <= guess;
          }
          if (below >= want) d = near.data(), m = below;
        }
        if (m >= want) {
          // The point itself is among the `want` nearest at 0: their root sum is PCL's sum over the k others.
          const Smallest sel =
              smallest(d, m, want, last_kth >= 0.0f ? last_kth : d[m / 2], s1.data(), s2.data());
          last_kth = sel.kth;
          if (reach >= 0.0f && sel.kth <= reach * reach) {
            mean_distance[finite[order[q]]] = static_cast<float>(sel.root_sum / mean_k);
            continue;
          }
        }
        tree.knnSearch(p.data(), want, idx.data(), d2.data());  // the neighbours reach beyond the block
        mean_distance[finite[order[q]]] = mean_of(d2.data());
      }
    }
  }
  return mean_distance;
}

std::vector<int> statistical_inliers(const std::vector<Eigen::Vector3f>& points, int mean_k,
                                     double stddev_mul) {
  const std::vector<float> mean_distance = mean_neighbour_distances(points, mean_k);
  int valid = 0;
  if (mean_k > 0)
    for (const Eigen::Vector3f& p : points) valid += p.allFinite();
  // PCL's statistics and threshold.
  double sum = 0.0, sq_sum = 0.0;
  for (float d : mean_distance) sum += d, sq_sum += d * d;
  const double mean = sum / valid;
  const double stddev = std::sqrt((sq_sum - sum * sum / valid) / (valid - 1.0));
  const double threshold = mean + stddev_mul * stddev;
  std::vector<int> kept;
  for (size_t i = 0; i < points.size(); ++i)
    if (!(mean_distance[i] > threshold)) kept.push_back(static_cast<int>(i));
  return kept;
}

std::vector<std::vector<int>> euclidean_clusters(const std::vector<Eigen::Vector3f>& points, float tolerance,
                                                 size_t min_size, size_t max_size) {
  const size_t n = points.size();
  std::vector<std::vector<int>> clusters;
  if (n == 0) return clusters;
  // Neighbours: squared distance below the squared radius, each in float as nanoflann sums it.
  const float r2 = static_cast<float>(static_cast<double>(tolerance) * static_cast<double>(tolerance));
  // Cells a little wider than the radius: two points nearer than it lie in the same or adjacent cells, float
  // rounding of the cell coordinates included.
  const float cell = tolerance * 1.001f;
  Eigen::Vector3f lo = points.front();
  for (const Eigen::Vector3f& p : points) lo = lo.cwiseMin(p);
  auto cell_of = [&](const Eigen::Vector3f& p) {
    Eigen::Array3i c;
    for (int a = 0; a < 3; ++a) c[a] = static_cast<int>(std::floor((p[a] - lo[a]) / cell));
    return c;
  };
  auto key_of = [](const Eigen::Array3i& c) {
    return (static_cast<uint64_t>(c[2]) << 42) | (static_cast<uint64_t>(c[1]) << 21) |
           static_cast<uint64_t>(c[0]);
  };
  std::vector<std::pair<uint64_t, uint32_t>> by_cell(n);
  for (size_t i = 0; i < n; ++i) by_cell[i] = {key_of(cell_of(points[i])), static_cast<uint32_t>(i)};
  std::sort(by_cell.begin(), by_cell.end());

  std::vector<uint32_t> parent(n);
  for (size_t i = 0; i < n; ++i) parent[i] = static_cast<uint32_t>(i);
  auto root = [&](uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto close = [&](uint32_t i, uint32_t j) {
    const Eigen::Vector3f& p = points[i];
    const Eigen::Vector3f& q = points[j];
    const float dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
    return dx * dx + dy * dy + dz * dz < r2;
  };
  // Every cell against itself and the 13 of its 26 neighbours with a greater key: each pair of cells once.
  for (size_t a = 0; a < n;) {
    size_t a_end = a;
    while (a_end < n && by_cell[a_end].first == by_cell[a].first) ++a_end;
    const Eigen::Array3i c = cell_of(points[by_cell[a].second]);
    for (size_t i = a; i < a_end; ++i)
      for (size_t j = i + 1; j < a_end; ++j)
        if (close(by_cell[i].second, by_cell[j].second))
          parent[root(by_cell[i].second)] = root(by_cell[j].second);
    for (int dz = 0; dz <= 1; ++dz)
      for (int dy = dz ? -1 : 0; dy <= 1; ++dy)
        for (int dx = dz || dy ? -1 : 1; dx <= 1; ++dx) {
          const Eigen::Array3i d = c + Eigen::Array3i(dx, dy, dz);
          if ((d < 0).any()) continue;
          const uint64_t key = key_of(d);
          auto b = std::lower_bound(by_cell.begin() + static_cast<long>(a_end), by_cell.end(),
                                    std::make_pair(key, uint32_t{0}));
          for (; b != by_cell.end() && b->first == key; ++b)
            for (size_t i = a; i < a_end; ++i)
              if (close(by_cell[i].second, b->second)) parent[root(by_cell[i].second)] = root(b->second);
        }
    a = a_end;
  }
  // Clusters in the order of their first point (PCL seeds a cluster at the first point not yet taken).
  std::vector<int> slot(n, -1);
  std::vector<std::vector<int>> all;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t r = root(static_cast<uint32_t>(i));
    if (slot[r] < 0) slot[r] = static_cast<int>(all.size()), all.emplace_back();
    all[static_cast<size_t>(slot[r])].push_back(static_cast<int>(i));
  }
  for (std::vector<int>& c : all)
    if (c.size() >= min_size && c.size() <= max_size) clusters.push_back(std::move(c));
  // PCL's final order: its sort (not stable) by size on the reversed sequence, with the same comparisons.
  std::sort(clusters.rbegin(), clusters.rend(),
            [](const std::vector<int>& x, const std::vector<int>& y) { return x.size() < y.size(); });
  return clusters;
}

}  // namespace weldtwin
