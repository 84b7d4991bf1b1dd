#include "sim/convex_pieces.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace weldtwin {
namespace {

using Polygon = std::vector<Vec3>;

// The part of a convex polygon where x[axis] >= at (above) or x[axis] <= at (below).
Polygon clip(const Polygon& in, int axis, double at, bool above) {
  Polygon out;
  for (size_t i = 0; i < in.size(); ++i) {
    const Vec3& a = in[i];
    const Vec3& b = in[(i + 1) % in.size()];
    const double da = above ? a[axis] - at : at - a[axis];
    const double db = above ? b[axis] - at : at - b[axis];
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// Whether the points span a volume MuJoCo can take the hull of: four or more, not all on one plane.
bool spans_volume(const std::vector<Vec3>& pts) {
  if (pts.size() < 4) return false;
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Mat3 cov = Mat3::Zero();
  for (const Vec3& p : pts) cov += (p - mean) * (p - mean).transpose();
  cov /= static_cast<double>(pts.size());
  const double thinnest = Eigen::SelfAdjointEigenSolver<Mat3>(cov).eigenvalues()[0];
  return thinnest > 1e-5 * 1e-5;  // 10 um
}

// The points once each, at 0.1 um.
void unique_points(std::vector<Vec3>& pts) {
  std::vector<std::array<long long, 3>> keys;
  keys.reserve(pts.size());
  for (const Vec3& p : pts)
    keys.push_back({std::llround(p.x() * 1e7), std::llround(p.y() * 1e7), std::llround(p.z() * 1e7)});
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  pts.clear();
  for (const auto& k : keys)
    pts.emplace_back(static_cast<double>(k[0]) * 1e-7, static_cast<double>(k[1]) * 1e-7,
                     static_cast<double>(k[2]) * 1e-7);
}

}  // namespace

std::vector<std::vector<Vec3>> convex_pieces(const Mesh& mesh, const ConvexPiecesSetting& setting) {
  if (mesh.vertices.empty() || mesh.faces.empty()) return {};
  Vec3 lo = mesh.vertices.front(), hi = lo;
  for (const Vec3& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const double extent = hi[axis] - lo[axis];
  const int n = std::max(1, static_cast<int>(std::ceil(extent / std::max(setting.max_slab_m, 1e-6) - 1e-9)));
  const double thick = extent / n;
  auto plane = [&](int k) { return k == n ? hi[axis] : lo[axis] + thick * k; };

  std::vector<std::vector<Vec3>> slabs(static_cast<size_t>(n));
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Polygon tri{mesh.vertices[static_cast<size_t>(f[0])], mesh.vertices[static_cast<size_t>(f[1])],
                      mesh.vertices[static_cast<size_t>(f[2])]};
    const double a = std::min({tri[0][axis], tri[1][axis], tri[2][axis]});
    const double b = std::max({tri[0][axis], tri[1][axis], tri[2][axis]});
    const int first = std::clamp(static_cast<int>(std::floor((a - lo[axis]) / thick)), 0, n - 1);
    const int last = std::clamp(static_cast<int>(std::floor((b - lo[axis]) / thick)), 0, n - 1);
    for (int k = first; k <= last; ++k) {
      const Polygon part = clip(clip(tri, axis, plane(k), true), axis, plane(k + 1), false);
      std::vector<Vec3>& slab = slabs[static_cast<size_t>(k)];
      slab.insert(slab.end(), part.begin(), part.end());
    }
  }

  std::vector<std::vector<Vec3>> pieces;
  std::vector<Vec3> carry;  // a slab too thin to stand alone goes into the next
  for (std::vector<Vec3>& slab : slabs) {
    slab.insert(slab.end(), carry.begin(), carry.end());
    unique_points(slab);
    if (spans_volume(slab)) {
      pieces.push_back(std::move(slab));
      carry.clear();
    } else {
      carry = std::move(slab);
    }
  }
  if (!carry.empty() && !pieces.empty()) {
    pieces.back().insert(pieces.back().end(), carry.begin(), carry.end());
    unique_points(pieces.back());
  }
  return pieces;
}

}  // namespace weldtwin
