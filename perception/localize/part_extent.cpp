#include "perception/localize/part_extent.hpp"

#include <algorithm>
#include <cmath>

#include "perception/localize/mesh_edges.hpp"

namespace weldtwin {
namespace {

constexpr double kConvex = 1e-7;  // the other face's far vertex lies this far behind a face's plane [m]

const Vec3& vertex(const Mesh& m, size_t face, int k) {
  return m.vertices[static_cast<size_t>(m.faces[face][k])];
}

// The vertex of `face` not on the edge ab.
Vec3 far_vertex(const Mesh& m, size_t face, const Vec3& a, const Vec3& b) {
  Vec3 best = vertex(m, face, 0);
  double d = -1.0;
  for (int k = 0; k < 3; ++k) {
    const Vec3& v = vertex(m, face, k);
    const double e = std::min((v - a).squaredNorm(), (v - b).squaredNorm());
    if (e > d) d = e, best = v;
  }
  return best;
}

}  // namespace

void beyond_edge_samples(const Mesh& rest, PartModel& model, const PartModelSetting& s) {
  std::vector<Vec3>& out = model.beyond;
  out.clear();
  model.beyond_dist.clear();
  const double cos_sharp = std::cos(deg2rad(s.sharp_edge_deg));
  for (const MeshEdge& e : mesh_edges(rest)) {
    if (e.faces.size() != 2 || e.normals[0].dot(e.normals[1]) >= cos_sharp) continue;
    const Vec3 &a = rest.vertices[e.a], &b = rest.vertices[e.b];
    const double len = (b - a).norm();
    if (len < s.beyond_step_m) continue;
    const Vec3 along = (b - a) / len;
    // Convex: each face's far vertex lies behind the other face's plane.
    if ((far_vertex(rest, e.faces[1], a, b) - a).dot(e.normals[0]) > -kConvex) continue;
    for (int side = 0; side < 2; ++side) {
      const Vec3& n = e.normals[static_cast<size_t>(side)];
      Vec3 u = along.cross(n);
      if (u.dot(far_vertex(rest, e.faces[static_cast<size_t>(side)], a, b) - a) > 0) u = -u;
      for (double t = 0.5 * s.beyond_step_m; t < len; t += s.beyond_step_m)
        for (double d : s.beyond_m) {
          const Vec3 q = a + t * along + d * u;
          if (q.z() <= 0.0) continue;  // under the table
          double d2 = 0.0;
          if (model.pts.empty() || model.tree.nearest_within(q, s.beyond_clearance_share * d, d2) >= 0)
            continue;
          if (model.rays && view_directions(*model.rays, q, n) == 0) continue;  // no scanner sees it
          out.push_back(q);
          model.beyond_dist.push_back(static_cast<float>(d));
        }
    }
  }
}

PartExtent scan_beyond_model(const ScenePoints& scene, const PartModel& model, const Iso3& P,
                             const PartExtentSetting& s) {
  PartExtent out;
  const Iso3 T = P.inverse();
  const double reach = std::max(s.min_reach_m, s.reach_sigmas * scene.limits.noise_m);
  const double low = scene.limits.height_cut_m + reach;
  // Ranges' noise spills points past an edge along grazing rays: only samples clear of that count.
  const double least = reach + s.spill_sigmas * scene.limits.noise_m;
  double d2 = 0.0;
  std::vector<Vec3> on;
  for (size_t i = 0; i < model.beyond.size(); ++i) {
    const Vec3& q = model.beyond[i];
    if (q.z() < low || model.beyond_dist[i] < least) continue;
    ++out.samples;
    if (scene.tree.nearest_within(T * q, reach, d2) >= 0) on.push_back(q);
  }
  out.supported = static_cast<int>(on.size());
  // Groups by single linkage (union-find over the pairs closer than link_m).
  std::vector<size_t> root(on.size());
  for (size_t i = 0; i < on.size(); ++i) root[i] = i;
  auto find = [&](size_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  const double link2 = s.link_m * s.link_m;
  for (size_t i = 0; i < on.size(); ++i)
    for (size_t j = i + 1; j < on.size(); ++j)
      if ((on[i] - on[j]).squaredNorm() < link2) root[find(i)] = find(j);
  std::vector<Vec3> lo(on.size(), Vec3::Constant(1e9)), hi(on.size(), Vec3::Constant(-1e9));
  for (size_t i = 0; i < on.size(); ++i) {
    const size_t r = find(i);
    lo[r] = lo[r].cwiseMin(on[i]);
    hi[r] = hi[r].cwiseMax(on[i]);
  }
  for (size_t r = 0; r < on.size(); ++r) {
    if (find(r) != r) continue;
    const double e = (hi[r] - lo[r]).norm();
    if (e > out.extent_m) {
      out.extent_m = e;
      out.centre = 0.5 * (lo[r] + hi[r]);
    }
  }
  return out;
}

}  // namespace weldtwin
