#include "perception/localize/part_extent.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "perception/localize/mesh_edges.hpp"

namespace weldtwin {
namespace {

constexpr double kConvex = 1e-7;  // the other face's far vertex lies this far behind a face's plane [m]
constexpr double kOnLine = 1e-4;  // an edge's ends this close to another edge's line lie on it [m]

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

// A convex feature edge: its ends (and their merged ids), and per side the face's normal and the direction
// past the edge.
struct ConvexEdge {
  Vec3 a, b;
  std::array<int, 2> ends;
  std::array<Vec3, 2> n, u;
};

std::vector<ConvexEdge> convex_edges(const Mesh& rest, const PartModelSetting& s) {
  std::vector<ConvexEdge> out;
  const double cos_sharp = std::cos(deg2rad(s.sharp_edge_deg));
  for (const MeshEdge& e : mesh_edges(rest)) {
    if (e.faces.size() != 2 || e.normals[0].dot(e.normals[1]) >= cos_sharp) continue;
    const Vec3 &a = rest.vertices[e.a], &b = rest.vertices[e.b];
    if ((b - a).norm() < s.beyond_step_m) continue;
    // Convex: each face's far vertex lies behind the other face's plane.
    if ((far_vertex(rest, e.faces[1], a, b) - a).dot(e.normals[0]) > -kConvex) continue;
    ConvexEdge c{a, b, {e.id_a, e.id_b}, {}, {}};
    const Vec3 along = (b - a).normalized();
    for (size_t side = 0; side < 2; ++side) {
      c.n[side] = e.normals[side];
      c.u[side] = along.cross(c.n[side]);
      if (c.u[side].dot(far_vertex(rest, e.faces[side], a, b) - a) > 0) c.u[side] = -c.u[side];
    }
    out.push_back(c);
  }
  return out;
}

bool on_line(const Vec3& p, const ConvexEdge& line) {
  const Vec3 d = (line.b - line.a).normalized();
  const Vec3 r = p - line.a;
  return (r - r.dot(d) * d).norm() < kOnLine;
}

// The straight lines the edges make: a mesh may cut one edge of the part into several.
struct EdgeLines {
  std::vector<int> of_edge;   ///< each edge's line, numbered from 0 (edges on one line, joined end to end)
  std::vector<size_t> first;  ///< each line's first edge (it names the line's two sides)
};

EdgeLines edge_lines(const std::vector<ConvexEdge>& edges) {
  std::map<int, std::vector<size_t>> at;  // the edges at each end
  for (size_t k = 0; k < edges.size(); ++k)
    for (int end : edges[k].ends) at[end].push_back(k);
  EdgeLines out;
  out.of_edge.assign(edges.size(), -1);
  for (size_t seed = 0; seed < edges.size(); ++seed) {
    if (out.of_edge[seed] >= 0) continue;
    const int line = static_cast<int>(out.first.size());
    out.first.push_back(seed);
    out.of_edge[seed] = line;
    std::vector<size_t> todo{seed};
    while (!todo.empty()) {
      const size_t k = todo.back();
      todo.pop_back();
      for (int end : edges[k].ends)
        for (size_t j : at[end])
          if (out.of_edge[j] < 0 && on_line(edges[j].a, edges[seed]) && on_line(edges[j].b, edges[seed])) {
            out.of_edge[j] = line;
            todo.push_back(j);
          }
    }
  }
  return out;
}

}  // namespace

void beyond_edge_samples(const Mesh& rest, PartModel& model, const PartModelSetting& s) {
  std::vector<Vec3>& out = model.beyond;
  out.clear();
  model.beyond_dist.clear();
  model.beyond_line.clear();
  model.beyond_line_length.clear();
  const std::vector<ConvexEdge> edges = convex_edges(rest, s);
  const EdgeLines lines = edge_lines(edges);
  model.beyond_line_length.assign(2 * lines.first.size(), 0.0f);
  for (size_t k = 0; k < edges.size(); ++k) {
    const ConvexEdge& e = edges[k];
    const double len = (e.b - e.a).norm();
    const Vec3 along = (e.b - e.a) / len;
    const int line = lines.of_edge[k];
    // A face continued past an edge is one side of its line, as the line's first edge names them.
    const ConvexEdge& named = edges[lines.first[static_cast<size_t>(line)]];
    for (size_t side = 0; side < 2; ++side) {
      const Vec3& n = e.n[side];
      const int group = 2 * line + (n.dot(named.n[0]) >= n.dot(named.n[1]) ? 0 : 1);
      model.beyond_line_length[static_cast<size_t>(group)] += static_cast<float>(len);
      const bool up = e.u[side].z() >= s.beyond_up_min_z;
      for (double t = 0.5 * s.beyond_step_m; t < len; t += s.beyond_step_m)
        for (double d : s.beyond_m) {
          const Vec3 q = e.a + t * along + d * e.u[side];
          if (q.z() <= 0.0) continue;  // under the table
          double d2 = 0.0;
          if (model.pts.empty() || model.tree.nearest_within(q, s.beyond_clearance_share * d, d2) >= 0)
            continue;
          if (model.rays && view_directions(*model.rays, q, n) == 0) continue;  // no scanner sees it
          out.push_back(q);
          model.beyond_dist.push_back(static_cast<float>(d));
          // A wall continued up into open air (nothing of the part above it) is judged per edge.
          const bool open = up && model.rays && !std::isfinite(model.rays->hit(q, Vec3::UnitZ()));
          model.beyond_line.push_back(open ? group : -1);
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
  const size_t groups = model.beyond_line_length.size();
  std::vector<int> counted(groups, 0), held(groups, 0);
  std::vector<Vec3> held_sum(groups, Vec3::Zero());
  for (size_t i = 0; i < model.beyond.size(); ++i) {
    const Vec3& q = model.beyond[i];
    if (q.z() < low || model.beyond_dist[i] < least) continue;
    ++out.samples;
    const int g = model.beyond_line[i];
    if (g >= 0) ++counted[static_cast<size_t>(g)];
    if (scene.tree.nearest_within(T * q, reach, d2) < 0) continue;
    on.push_back(q);
    if (g < 0) continue;
    ++held[static_cast<size_t>(g)];
    held_sum[static_cast<size_t>(g)] += q;
  }
  out.supported = static_cast<int>(on.size());
  for (size_t g = 0; g < groups; ++g) {
    if (model.beyond_line_length[g] < s.min_line_m || counted[g] < s.min_line_samples) continue;
    const double share = static_cast<double>(held[g]) / counted[g];
    if (share <= out.line_share) continue;
    out.line_share = share;
    out.line_length_m = model.beyond_line_length[g];
    out.line_centre = held_sum[g] / held[g];
  }
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
