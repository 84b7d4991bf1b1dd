#include "perception/neighbour_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace weldtwin {
namespace {

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

constexpr double kPi = 3.14159265358979323846;

struct Block;

// Points sorted into cubic cells by a counting sort, to gather the points of blocks of cells.
struct CellGrid {
  Eigen::Vector3f lo;
  float cell;
  long n[3];
  std::vector<uint32_t> start, order, of;  ///< a cell's points: order[start[cell]..start[cell + 1])

  CellGrid(const std::vector<Eigen::Vector3f>& pts, float cell_m, const Eigen::Vector3f& lo_m,
           const Eigen::Vector3f& hi_m)
      : lo(lo_m), cell(std::max(cell_m, 1e-5f)) {
    for (;;) {
      for (int a = 0; a < 3; ++a) n[a] = static_cast<long>(std::floor((hi_m[a] - lo[a]) / cell)) + 1;
      if (static_cast<double>(n[0]) * static_cast<double>(n[1]) * static_cast<double>(n[2]) <= 16e6) break;
      cell *= 1.5f;
    }
    const size_t cells = static_cast<size_t>(n[0] * n[1] * n[2]);
    start.assign(cells + 1, 0);
    of.resize(pts.size());
    long c[3];
    for (size_t i = 0; i < pts.size(); ++i) {
      cell_of(pts[i], c);
      ++start[(of[i] = static_cast<uint32_t>((c[2] * n[1] + c[1]) * n[0] + c[0])) + 1];
    }
    for (size_t k = 0; k < cells; ++k) start[k + 1] += start[k];
    order.resize(pts.size());
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (size_t i = 0; i < pts.size(); ++i) order[fill[of[i]]++] = static_cast<uint32_t>(i);
  }

  void cell_of(const Eigen::Vector3f& p, long c[3]) const {
    for (int a = 0; a < 3; ++a) c[a] = std::min(n[a] - 1, static_cast<long>((p[a] - lo[a]) / cell));
  }

  /// How near p a point outside the block of cells within r of c can be: the distance to the nearest face of
  /// the block with cells beyond it (infinite when the block covers the grid), less a rounding margin.
  float reach(const Eigen::Vector3f& p, const long c[3], long r) const {
    float out = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (c[a] - r > 0) out = std::min(out, p[a] - (lo[a] + static_cast<float>(c[a] - r) * cell));
      if (c[a] + r + 1 < n[a]) out = std::min(out, lo[a] + static_cast<float>(c[a] + r + 1) * cell - p[a]);
    }
    return out - 1e-5f * cell;
  }

  bool covers_all(const long c[3], long r) const {
    for (int a = 0; a < 3; ++a)
      if (c[a] - r > 0 || c[a] + r + 1 < n[a]) return false;
    return true;
  }

  /// The `want` nearest of p exactly (want <= the number of points): blocks of cells around p's cell, r = r0,
  /// 2 r0, 4 r0, ..., until the want-th is nearer than the block's faces.
  Smallest nearest(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3f& p, size_t want, long r0,
                   Block& block) const;
};

// The points of a block of cells, by coordinate, and room for their distances to one point.
struct Block {
  std::vector<float> x, y, z, dist, near, s1, s2;

  void gather(const CellGrid& g, const std::vector<Eigen::Vector3f>& pts, const long c[3], long r) {
    x.clear(), y.clear(), z.clear();
    for (long k = std::max(0L, c[2] - r); k <= std::min(g.n[2] - 1, c[2] + r); ++k)
      for (long j = std::max(0L, c[1] - r); j <= std::min(g.n[1] - 1, c[1] + r); ++j) {
        const size_t row = static_cast<size_t>((k * g.n[1] + j) * g.n[0]);
        for (uint32_t i = g.start[row + static_cast<size_t>(std::max(0L, c[0] - r))],
                      end = g.start[row + static_cast<size_t>(std::min(g.n[0] - 1, c[0] + r)) + 1];
             i < end; ++i) {
          const Eigen::Vector3f& p = pts[g.order[i]];
          x.push_back(p.x()), y.push_back(p.y()), z.push_back(p.z());
        }
      }
    dist.resize(x.size()), near.resize(x.size()), s1.resize(x.size()), s2.resize(x.size());
  }

  /// Squared distances to p, each summed in PCL's (FLANN's) order.
  void distances(const Eigen::Vector3f& p) {
    for (size_t j = 0; j < x.size(); ++j) {
      const float ex = x[j] - p.x(), ey = y[j] - p.y(), ez = z[j] - p.z();
      dist[j] = ex * ex + ey * ey + ez * ez;
    }
  }
};

Smallest CellGrid::nearest(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3f& p, size_t want,
                           long r0, Block& block) const {
  long c[3];
  cell_of(p, c);
  for (long r = r0;; r *= 2) {
    block.gather(*this, pts, c, r);
    if (block.dist.size() >= want) {
      block.distances(p);
      const Smallest sel = smallest(block.dist.data(), block.dist.size(), want,
                                    block.dist[block.dist.size() / 2], block.s1.data(), block.s2.data());
      const float R = reach(p, c, r);
      if (covers_all(c, r) || (R > 0.0f && sel.kth <= R * R)) return sel;
    }
  }
}

}  // namespace

std::vector<float> mean_neighbour_distances(const std::vector<Eigen::Vector3f>& points, int mean_k) {
  std::vector<uint32_t> finite;
  std::vector<Eigen::Vector3f> pts;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].allFinite()) finite.push_back(static_cast<uint32_t>(i)), pts.push_back(points[i]);
  std::vector<float> mean_distance(points.size(), 0.0f);
  if (pts.empty() || mean_k <= 0) return mean_distance;
  const size_t want = std::min(static_cast<size_t>(mean_k) + 1, pts.size());  // the point itself first
  Eigen::Vector3f lo = pts.front(), hi = pts.front();
  for (const Eigen::Vector3f& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  Block block, wide;

  // The cell: within it nine points in ten have their neighbours, from a thousand of them searched on a
  // first grid whose cell assumes the points spread over the footprint of their box (a surface seen from
  // above, as a table scan is; any other spread only makes that search take more rings).
  float cell = 0.0f;
  {
    const double area = std::max(1e-12, static_cast<double>(hi.x() - lo.x()) * (hi.y() - lo.y()));
    const CellGrid first(pts,
                         static_cast<float>(std::sqrt(area * static_cast<double>(want) /
                                                      (kPi * static_cast<double>(pts.size())))),
                         lo, hi);
    std::vector<float> kth;
    for (size_t i = 0; i < pts.size(); i += std::max<size_t>(1, pts.size() / 1000))
      kth.push_back(std::sqrt(first.nearest(pts, pts[i], want, 1, block).kth));
    std::nth_element(kth.begin(), kth.begin() + static_cast<long>(kth.size() * 9 / 10), kth.end());
    cell = kth[kth.size() * 9 / 10];
  }
  const CellGrid grid(pts, cell, lo, hi);

  for (size_t o = 0; o < grid.order.size();) {
    // The points of this cell, and every point of the block of cells around it.
    const size_t first = o, here = grid.of[grid.order[o]];
    while (o < grid.order.size() && grid.of[grid.order[o]] == here) ++o;
    long c[3];
    grid.cell_of(pts[grid.order[first]], c);
    block.gather(grid, pts, c, 1);
    float last_kth = -1.0f;  // squared
    for (size_t q = first; q < o; ++q) {
      const Eigen::Vector3f& p = pts[grid.order[q]];
      const float reach = grid.reach(p, c, 1);
      block.distances(p);
      // Neighbouring points have about the same k-th distance: select among the distances below a guess
      // from the last one when there are enough of them, else among all; the last k-th the first pivot.
      float* d = block.dist.data();
      size_t m = block.dist.size();
      if (last_kth >= 0.0f) {
        const float guess = 1.5f * last_kth;
        size_t below = 0;
        for (size_t j = 0; j < block.dist.size(); ++j) {
          block.near[below] = block.dist[j];
          below += block.dist[j] <= guess;
        }
        if (below >= want) d = block.near.data(), m = below;
      }
      Smallest sel{0.0f, 0.0f};
      const bool selected = m >= want;
      if (selected) {
        sel = smallest(d, m, want, last_kth >= 0.0f ? last_kth : d[m / 2], block.s1.data(), block.s2.data());
        last_kth = sel.kth;
      }
      if (!selected || !(reach > 0.0f && sel.kth <= reach * reach)) {
        // The neighbours reach beyond the block: wider blocks around this point alone.
        sel = grid.nearest(pts, p, want, 2, wide);
      }
      // The point itself is among the `want` nearest at 0: their root sum is PCL's sum over the k others.
      mean_distance[finite[grid.order[q]]] = static_cast<float>(sel.root_sum / mean_k);
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
  // Cells a little wider than the radius (the grid may widen them): two points nearer than it lie in the same
  // or adjacent cells, float rounding of the cell coordinates included.
  Eigen::Vector3f lo = points.front(), hi = points.front();
  for (const Eigen::Vector3f& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const CellGrid grid(points, tolerance * 1.001f, lo, hi);

  std::vector<uint32_t> parent(n);
  for (size_t i = 0; i < n; ++i) parent[i] = static_cast<uint32_t>(i);
  auto root = [&](uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto join_close = [&](uint32_t i, uint32_t j) {
    const Eigen::Vector3f& p = points[i];
    const Eigen::Vector3f& q = points[j];
    const float dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
    if (dx * dx + dy * dy + dz * dz < r2) parent[root(i)] = root(j);
  };
  // Every cell against itself and the 13 of its 26 neighbours that follow it: each pair of cells once.
  const std::vector<uint32_t>& order = grid.order;
  for (size_t a = 0; a < n;) {
    const size_t here = grid.of[order[a]];
    size_t a_end = a;
    while (a_end < n && grid.of[order[a_end]] == here) ++a_end;
    long c[3];
    grid.cell_of(points[order[a]], c);
    for (size_t i = a; i < a_end; ++i)
      for (size_t j = i + 1; j < a_end; ++j) join_close(order[i], order[j]);
    for (long dz = 0; dz <= 1; ++dz)
      for (long dy = dz ? -1 : 0; dy <= 1; ++dy)
        for (long dx = dz || dy ? -1 : 1; dx <= 1; ++dx) {
          const long x = c[0] + dx, y = c[1] + dy, z = c[2] + dz;
          if (x < 0 || y < 0 || x >= grid.n[0] || y >= grid.n[1] || z >= grid.n[2]) continue;
          const size_t cell = static_cast<size_t>((z * grid.n[1] + y) * grid.n[0] + x);
          for (uint32_t k = grid.start[cell]; k < grid.start[cell + 1]; ++k)
            for (size_t i = a; i < a_end; ++i) join_close(order[i], order[k]);
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
