#include "perception/localize/see_through.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace weldtwin {
namespace {

// Whether the segment from a to b meets the box [lo, hi] (slab test).
bool crosses_box(const Vec3& a, const Vec3& b, const Vec3& lo, const Vec3& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Vec3 d = b - a;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double u = (lo[k] - a[k]) / d[k], v = (hi[k] - a[k]) / d[k];
    if (u > v) std::swap(u, v);
    t0 = std::max(t0, u);
    t1 = std::min(t1, v);
    if (t0 > t1) return false;
  }
  return true;
}

// The cube of `region_m` holding p, as one key.
long long region_key(const Vec3& p, double region_m) {
  constexpr long long kSpan = 1 << 20;  // cubes per axis (a part a few metres wide at 25 mm uses 200)
  auto index = [&](double v) { return static_cast<long long>(std::floor(v / region_m)) + kSpan / 2; };
  return (index(p.x()) * kSpan + index(p.y())) * kSpan + index(p.z());
}

}  // namespace

SeeThrough rays_through_model(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                              const std::vector<Vec3>& viewpoints_base, const PartModel& model, const Iso3& P,
                              const SeeThroughSetting& s, const RayMatchSetting& edges) {
  SeeThrough out;
  if (!model.rays || scene.ray_points.empty() || viewpoints_base.size() != scan_base.size()) return out;
  const Iso3 T = P * scene.T_table_base;  // base frame -> part frame
  const Vec3 lo = model.lo - Vec3::Constant(s.box_margin_m), hi = model.hi + Vec3::Constant(s.box_margin_m);
  const double behind = std::max(s.min_behind_m, s.behind_sigmas * scene.limits.noise_m);
  const double short_of = std::max(s.reach_min_m, s.reach_sigmas * scene.limits.noise_m);
  out.reached.assign(model.pts.size(), 0);
  std::vector<uint32_t> idx;
  std::vector<double> d2;
  std::vector<uint32_t> crossing;
  struct Region {
    int met = 0, through = 0;
    Vec3 at = Vec3::Zero();
  };
  std::unordered_map<long long, Region> regions;
  for (uint32_t i : scene.ray_points) {
    const Vec3 q = T * scan_base[i], o = T * viewpoints_base[i];
    if (crosses_box(o, q, lo, hi)) crossing.push_back(i);
  }
  const size_t stride = std::max<size_t>(1, crossing.size() / static_cast<size_t>(std::max(1, s.max_rays)));
  for (size_t k = 0; k < crossing.size(); k += stride) {
    const uint32_t i = crossing[k];
    const Vec3 q = T * scan_base[i], o = T * viewpoints_base[i];
    const double range = (q - o).norm();
    if (range <= behind) continue;
    ++out.rays;
    const Vec3 d = (q - o) / range;
    const double t = model.rays->hit(o, d, 0.0, range + short_of);
    if (!std::isfinite(t)) continue;  // the ray misses the model, or stopped short of it
    const Vec3 hit = o + t * d;
    Region& region = regions[region_key(hit, s.region_m)];
    ++region.met;
    if (t < range - behind) {
      ++out.through;
      if (!ray_near_depth_edge(model, o, d, t, range, edges)) {
        ++region.through;
        region.at =
            s.region_m * (hit / s.region_m).array().floor().matrix() + Vec3::Constant(0.5 * s.region_m);
      }
    }
    // It reached the model's surface, whether its point lies there or behind.
    if (model.tree.knn(hit, static_cast<size_t>(s.reach_neighbours), idx, d2) == 0) continue;
    // Samples of the face the ray met, not of the wall's other face a few millimetres behind it.
    for (size_t j = 0; j < idx.size(); ++j)
      if (d2[j] <= s.reach_radius_m * s.reach_radius_m && model.nrm[idx[j]].dot(d) < 0.0)
        out.reached[idx[j]] = 1;
  }
  for (const auto& [key, r] : regions) {
    const bool seen_through =
        r.through >= s.min_region_through && r.through >= s.region_through_share * r.met;
    if (seen_through > out.region_seen_through ||
        (seen_through == out.region_seen_through && r.through > out.region_through)) {
      out.region_seen_through = seen_through;
      out.region_through = r.through;
      out.region_rays = r.met;
      out.region_at = r.at;
    }
  }
  return out;
}

}  // namespace weldtwin
