#include "perception/localize/ray_matching.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {

std::vector<ScanPoint> rays_near_pose(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                                      const std::vector<Vec3>& viewpoints_base, PartModel& model,
                                      const Iso3& P, const RayMatchSetting& s) {
  std::vector<ScanPoint> near;
  const double band = s.outline_band_m, deep = s.deep_edge_sigmas * scene.limits.noise_m + s.deep_edge_m;
  const double m = s.box_margin_m;
  auto on = [&](const Vec3& x) { return model.footprint.covers(x.x(), x.y()); };
  for (uint32_t i : scene.ray_points) {
    const Vec3 q = scene.T_table_base * scan_base[i];
    const Vec3 p = P * q;
    if (p.x() < model.lo.x() - m || p.y() < model.lo.y() - m || p.x() > model.hi.x() + m ||
        p.y() > model.hi.y() + m)
      continue;
    if (q.z() < scene.limits.height_cut_m) {
      const bool here = on(p);
      if (here == on(p + Vec3(band, 0, 0)) && here == on(p - Vec3(band, 0, 0)) &&
          here == on(p + Vec3(0, band, 0)) && here == on(p - Vec3(0, band, 0)))
        continue;
    } else {
      const int k = model.nearest(p);
      if (k >= 0 && std::abs(model.nrm[static_cast<size_t>(k)].z()) > s.level_normal_z &&
          (p - model.pts[static_cast<size_t>(k)]).norm() < s.deep_level_m &&
          model.edge_distance[static_cast<size_t>(k)] > deep)
        continue;
    }
    const Vec3 o = scene.T_table_base * viewpoints_base[i];
    const double range = (q - o).norm();
    if (range < 1e-6) continue;
    near.push_back({q, q, (q - o) / range, o, range});
  }
  return near;
}

bool ray_near_depth_edge(const PartModel& m, const Vec3& o, const Vec3& d, double t, double range,
                         const RayMatchSetting& s) {
  // Rays beside it, across it both ways, this far off where it meets the model (or at its point).
  const double reach = range + s.ray_window_m;
  const Vec3 a = d.unitOrthogonal(), b = d.cross(a);
  const double at = std::isfinite(t) ? t : range;
  for (const Vec3& e : {a, b, Vec3(-a), Vec3(-b)}) {
    const double t2 =
        m.rays->hit(o, (d + (s.beam_offset_m / at) * e).normalized(), 0.0, reach + s.depth_jump_m);
    if (std::isfinite(t) != std::isfinite(t2) || (std::isfinite(t) && std::abs(t2 - t) > s.depth_jump_m))
      return true;
  }
  return false;
}

std::vector<uint8_t> rays_near_depth_edges(const std::vector<ScanPoint>& rays, const PartModel& m,
                                           const Iso3& P, const RayMatchSetting& s) {
  std::vector<uint8_t> near(rays.size(), 0);
  for (size_t i = 0; i < rays.size(); ++i) {
    const ScanPoint& sp = rays[i];
    if (sp.range <= 0.0) continue;
    const Vec3 o = P * sp.origin, d = P.linear() * sp.ray;
    const double t = m.rays->hit(o, d, 0.0, sp.range + s.ray_window_m);
    near[i] = ray_near_depth_edge(m, o, d, t, sp.range, s);
  }
  return near;
}

void match_rays(const std::vector<ScanPoint>& scan, PartModel& m, const Iso3& P, double edge_margin,
                const RayMatchSetting& s, std::vector<int>& face) {
  face.assign(scan.size(), -1);
  // (faces seen from behind, and more obliquely than max_incidence_deg, are not met)
  const double min_cos_incidence = std::max(0.0, std::cos(deg2rad(s.max_incidence_deg)));
  for (size_t i = 0; i < scan.size(); ++i) {
    const ScanPoint& sp = scan[i];
    const Vec3 o = P * sp.origin, d = P.linear() * sp.ray;
    const double t = m.rays->hit(o, d, 0.0, sp.range + s.ray_window_m);
    if (!std::isfinite(t) || t < sp.range - s.ray_window_m) continue;  // the ray meets something else
    const Vec3 at = o + t * d;
    const int k = m.nearest(at);
    if (k < 0) continue;
    const size_t kk = static_cast<size_t>(k);
    // Level faces say nothing of (x, y, yaw); near a feature edge or the table, which face a ray meets
    // changes with the pose itself.
    if (std::abs(m.nrm[kk].z()) > s.level_normal_z || -m.nrm[kk].dot(d) <= min_cos_incidence ||
        !m.visible[kk] || m.edge_distance[kk] < edge_margin || at.z() < edge_margin)
      continue;
    face[i] = k;
  }
}

}  // namespace weldtwin
