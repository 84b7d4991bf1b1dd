#include "perception/localize/part_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "core/parallel_for.hpp"
#include "perception/localize/mesh_edges.hpp"
#include "perception/localize/part_extent.hpp"

namespace weldtwin {
namespace {

constexpr double kVertexKey = 1e6;       // vertices compared to a micrometre
constexpr double kUndersideZ = 1e-4;     // edges this close to the resting plane are the underside's [m]
constexpr double kFootprintTop = 1e-3;   // underside faces lie below this [m]
constexpr double kDownNormalZ = -0.9;    // ... and face down at least this steeply
constexpr double kDegenerate = 1e-14;    // a face with a smaller cross product has no normal
constexpr size_t kChunk = 512;           // samples per work item
constexpr double kWallNormalZ = 0.5;     // a sample with |n.z| below this is on a wall
constexpr float kFarFromEdges_m = 1.0f;  // the edge distance of a sample beyond edge_reach_m (or of a mesh
                                         // without feature edges)

// Feature edges of the mesh (where the faces meet at more than sharp_edge_deg, or a face has no neighbour),
// except along the underside resting on the table, as points edge_point_step_m apart.
std::vector<Vec3> feature_edge_points(const Mesh& mesh, double min_z, const PartModelSetting& s) {
  std::vector<Vec3> out;
  for (const MeshEdge& e : mesh_edges(mesh)) {
    const bool sharp =
        e.normals.size() != 2 || e.normals[0].dot(e.normals[1]) < std::cos(deg2rad(s.sharp_edge_deg));
    if (!sharp) continue;
    const Vec3 &a = mesh.vertices[e.a], &b = mesh.vertices[e.b];
    if (a.z() - min_z < kUndersideZ && b.z() - min_z < kUndersideZ) continue;
    const int n = std::max(1, static_cast<int>((b - a).norm() / s.edge_point_step_m));
    for (int k = 0; k <= n; ++k) out.push_back(a + (b - a) * (static_cast<double>(k) / n));
  }
  return out;
}

// Marks the cells of `grid` whose centres lie inside the triangle abc (x, y only).
void fill_triangle(Grid2& grid, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double x0 = std::min({a.x(), b.x(), c.x()}), x1 = std::max({a.x(), b.x(), c.x()});
  const double y0 = std::min({a.y(), b.y(), c.y()}), y1 = std::max({a.y(), b.y(), c.y()});
  auto side = [](const Vec3& p, const Vec3& q, double x, double y) {
    return (q.x() - p.x()) * (y - p.y()) - (q.y() - p.y()) * (x - p.x());
  };
  for (double y = grid.origin.y() + grid.cell * (std::floor((y0 - grid.origin.y()) / grid.cell) + 0.5);
       y <= y1; y += grid.cell)
    for (double x = grid.origin.x() + grid.cell * (std::floor((x0 - grid.origin.x()) / grid.cell) + 0.5);
         x <= x1; x += grid.cell) {
      const double s0 = side(a, b, x, y), s1 = side(b, c, x, y), s2 = side(c, a, x, y);
      if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) {
        const long i = grid.index(x, y);
        if (i >= 0) grid.on[static_cast<size_t>(i)] = 1;
      }
    }
}

// Whether face abc is part of the underside resting on the table.
bool on_underside(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 nn = (b - a).cross(c - a);
  return !(nn.norm() < kDegenerate || nn.normalized().z() > kDownNormalZ ||
           std::max({a.z(), b.z(), c.z()}) > kFootprintTop);
}

}  // namespace

int PartModel::nearest(const Vec3& p) {
  if (!p.allFinite()) return -1;
  const long ix = static_cast<long>((p.x() - cache_origin.x()) / cache_cell),
             iy = static_cast<long>((p.y() - cache_origin.y()) / cache_cell),
             iz = static_cast<long>((p.z() - cache_origin.z()) / cache_cell);
  if (p.x() < cache_origin.x() || p.y() < cache_origin.y() || p.z() < cache_origin.z() || ix >= cx ||
      iy >= cy || iz >= cz)
    return -1;
  int* slot = cache.slot(ix, iy, iz);
  const int stored = __atomic_load_n(slot, __ATOMIC_RELAXED);
  if (stored != 0) return stored - 2;
  const Vec3 c =
      cache_origin + cache_cell * Vec3(static_cast<double>(ix) + 0.5, static_cast<double>(iy) + 0.5,
                                       static_cast<double>(iz) + 0.5);
  double d2 = 0.0;
  const int known = tree.nearest_within(c, cache_margin, d2);
  __atomic_store_n(slot, known + 2, __ATOMIC_RELAXED);
  return known;
}

Mesh resting_mesh(const Mesh& mesh, double min_z) {
  Mesh rest = mesh;
  for (Vec3& v : rest.vertices) v.z() -= min_z;
  orient_outward(rest);  // a mesh file's winding is not to be trusted
  return rest;
}

void make_lookups(const Mesh& rest, const PartModelSetting& s, PartModel& model) {
  if (!model.rays) model.rays = std::make_unique<MeshRays>(rest);
  model.tree = PointTree(model.pts);
  model.surface = std::make_unique<ClosestGrid>(*model.rays, model.lo, model.hi, s.closest);
  model.cache_cell = s.lookup_cell_m;
  model.cache_margin = s.lookup_margin_m;
  model.cache_origin = model.lo - Vec3::Constant(model.cache_margin);
  const Vec3 ext = model.hi - model.lo + Vec3::Constant(2 * model.cache_margin);
  model.cx = static_cast<int>(ext.x() / model.cache_cell) + 1;
  model.cy = static_cast<int>(ext.y() / model.cache_cell) + 1;
  model.cz = static_cast<int>(ext.z() / model.cache_cell) + 1;
  model.cache = BrickSlots<int>(model.cx, model.cy, model.cz);
}

void build_part_model(const Mesh& mesh, double min_z, const PartModelSetting& s, int threads,
                      PartModel& model) {
  build_part_model_at_rest(resting_mesh(mesh, min_z), s, threads, model);
}

void build_part_model_at_rest(const Mesh& rest, const PartModelSetting& s, int threads, PartModel& model) {
  const SurfaceSamples all = sample_surface(rest, s.spacing_m, s.min_normal_z);
  model.rays = std::make_unique<MeshRays>(rest);
  const MeshRays& rays = *model.rays;
  model.spacing_m = s.spacing_m;
  model.pts = all.points;
  model.nrm = all.normals;
  const size_t n = model.pts.size();
  if (n == 0) return;  // a mesh smaller than the sample spacing: nothing to find (the localizer says so)
  model.visible.resize(n);
  model.view_score.resize(n);
  model.view_mask.resize(n);
  model.half_thickness.resize(n);
  model.lo = Vec3::Constant(1e9);
  model.hi = Vec3::Constant(-1e9);
  parallel_for((n + kChunk - 1) / kChunk, threads, [&](size_t chunk) {
    for (size_t k = chunk * kChunk; k < std::min(n, (chunk + 1) * kChunk); ++k) {
      const Vec3& p = model.pts[k];
      const Vec3& nn = model.nrm[k];
      model.view_score[k] = static_cast<uint8_t>(view_directions(rays, p, nn));
      model.visible[k] = model.view_score[k] > 0;
      model.view_mask[k] = view_mask(rays, p, nn);
      // Half the distance to the next surface behind the face or facing it: a residual beyond that may
      // belong to the other surface, so trimming there keeps thin walls unbiased.
      const double behind = rays.hit(p, -nn, 1e-5, s.thickness_probe_m),
                   front = rays.hit(p, nn, 1e-5, s.thickness_probe_m);
      model.half_thickness[k] = static_cast<float>(0.5 * std::min({behind, front, 2 * s.thickness_probe_m}));
    }
  });
  for (size_t k = 0; k < n; ++k) {
    const Vec3& p = model.pts[k];
    model.lo = model.lo.cwiseMin(p);
    model.hi = model.hi.cwiseMax(p);
    model.radius = std::max(model.radius, p.head<2>().norm());
  }
  model.height = model.hi.z();
  model.view_total = view_totals(model.view_mask, model.nrm);

  // Distance of every sample to the nearest feature edge.
  model.edge_distance.assign(n, kFarFromEdges_m);
  const std::vector<Vec3> edge_pts = feature_edge_points(rest, 0.0, s);
  if (!edge_pts.empty()) {
    const PointTree edge_tree(edge_pts);
    parallel_for((n + kChunk - 1) / kChunk, threads, [&](size_t chunk) {
      double d2 = 0.0;
      for (size_t k = chunk * kChunk; k < std::min(n, (chunk + 1) * kChunk); ++k)
        if (edge_tree.nearest_within(model.pts[k], s.edge_reach_m, d2) >= 0)
          model.edge_distance[k] = static_cast<float>(std::sqrt(d2));
    });
  }

  // Wall samples by height for the Hough vote.
  model.height_bin_m = s.height_bin_m;
  model.walls_by_height.assign(static_cast<size_t>(model.height / s.height_bin_m) + 2, {});
  for (size_t k = 0; k < n; k += 3)
    if (model.visible[k] && std::abs(model.nrm[k].z()) < kWallNormalZ)
      model.walls_by_height[static_cast<size_t>(std::max(0.0, model.pts[k].z()) / s.height_bin_m)].push_back(
          static_cast<int>(k));

  // Thin walls: how thick, and the directions across them (at most wall_directions, the most common first).
  {
    constexpr int kBins = 36;  // 5 deg bins of the wall normal's direction, modulo 180 deg
    std::vector<double> thick;
    std::vector<int> hist(kBins, 0);
    std::vector<Eigen::Vector2d> doubled(kBins, Eigen::Vector2d::Zero());  // mean direction per bin
    size_t walls = 0;
    for (size_t k = 0; k < n; ++k) {
      if (!model.visible[k] || std::abs(model.nrm[k].z()) >= kWallNormalZ) continue;
      ++walls;
      const double t = 2.0 * model.half_thickness[k];
      if (t >= s.thin_wall_max_m) continue;
      thick.push_back(t);
      double a = std::atan2(model.nrm[k].y(), model.nrm[k].x());
      if (a < 0) a += kPi;
      const size_t bin = static_cast<size_t>(std::min(kBins - 1, static_cast<int>(a / kPi * kBins)));
      ++hist[bin];
      doubled[bin] += Eigen::Vector2d(std::cos(2 * a), std::sin(2 * a));
    }
    if (walls > 0 &&
        static_cast<double>(thick.size()) >= s.thin_wall_min_share * static_cast<double>(walls)) {
      std::nth_element(thick.begin(), thick.begin() + static_cast<long>(thick.size() / 2), thick.end());
      model.thin_wall_m = thick[thick.size() / 2];
      std::vector<int> chosen;
      for (int pick = 0; pick < s.wall_directions; ++pick) {
        int best = -1;
        for (int b = 0; b < kBins; ++b) {
          bool far = hist[static_cast<size_t>(b)] > 0;
          for (int c : chosen) {
            const double gap = std::abs(b - c) * 180.0 / kBins;
            far = far && std::min(gap, 180.0 - gap) >= s.wall_direction_gap_deg;
          }
          if (far && (best < 0 || hist[static_cast<size_t>(b)] > hist[static_cast<size_t>(best)])) best = b;
        }
        if (best < 0) break;
        chosen.push_back(best);
        const Eigen::Vector2d& m2 = doubled[static_cast<size_t>(best)];
        const double a = 0.5 * std::atan2(m2.y(), m2.x());
        const Eigen::Vector2d d(std::cos(a), std::sin(a));
        model.wall_side_shifts.push_back(model.thin_wall_m * d);
        model.wall_side_shifts.push_back(-model.thin_wall_m * d);
      }
    }
  }

  // Footprint: the underside faces resting on the table.
  model.footprint.reset(model.lo.head<2>() - Eigen::Vector2d::Constant(s.footprint_margin_m),
                        model.hi.head<2>() + Eigen::Vector2d::Constant(s.footprint_margin_m),
                        s.footprint_cell_m);
  for (const auto& f : rest.faces) {
    const Vec3 &a = rest.vertices[static_cast<size_t>(f[0])], &b = rest.vertices[static_cast<size_t>(f[1])],
               &c = rest.vertices[static_cast<size_t>(f[2])];
    if (on_underside(a, b, c)) fill_triangle(model.footprint, a, b, c);
  }
  // The footprint's outline: edges of the underside used by one underside face only, away from corners.
  {
    std::map<std::array<long long, 4>, std::pair<int, Eigen::Vector2d>> edges;  // edge -> uses, outward
    auto key2 = [](const Vec3& v) {
      return std::array<long long, 2>{std::llround(v.x() * kVertexKey), std::llround(v.y() * kVertexKey)};
    };
    std::map<std::array<long long, 4>, std::pair<Vec3, Vec3>> ends;
    for (const auto& f : rest.faces) {
      const Vec3 v[3] = {rest.vertices[static_cast<size_t>(f[0])], rest.vertices[static_cast<size_t>(f[1])],
                         rest.vertices[static_cast<size_t>(f[2])]};
      if (!on_underside(v[0], v[1], v[2])) continue;
      for (int k = 0; k < 3; ++k) {
        const Vec3 &a = v[k], &b = v[(k + 1) % 3], &o = v[(k + 2) % 3];
        auto ka = key2(a), kb = key2(b);
        if (kb < ka) std::swap(ka, kb);
        const std::array<long long, 4> key{ka[0], ka[1], kb[0], kb[1]};
        Eigen::Vector2d e = (b - a).head<2>(), out(e.y(), -e.x());
        out.normalize();
        if (out.dot((o - a).head<2>()) > 0) out = -out;
        auto& entry = edges[key];
        ++entry.first;
        entry.second = out;
        ends[key] = {a, b};
      }
    }
    const double above = model.height + 0.01;  // rays down from just above the part
    for (const auto& [key, entry] : edges) {
      if (entry.first != 1) continue;
      const Vec3 &a = ends[key].first, &b = ends[key].second;
      const double len = (b - a).head<2>().norm();
      for (double t = s.outline_corner_m; t <= len - s.outline_corner_m; t += s.outline_step_m) {
        const Eigen::Vector2d at = a.head<2>() + (b - a).head<2>() * (t / len);
        const Eigen::Vector2d inside = at - s.outline_inside_m * entry.second;
        const double h = rays.hit(Vec3(inside.x(), inside.y(), above), -Vec3::UnitZ(), 0.0);
        if (!std::isfinite(h)) continue;
        model.outline.push_back({at, entry.second, above - h});
      }
    }
  }
  // The lowest surface above each footprint cell that is not the underside (the inner floor of a tube, the
  // top of a plate): the table can be seen there only if the part is not.
  for (size_t i = 0; i < model.footprint.on.size(); ++i) {
    if (!model.footprint.on[i]) continue;
    const Eigen::Vector2d xy = model.footprint.centre(static_cast<long>(i));
    const Vec3 top(xy.x(), xy.y(), model.height + 0.01);
    double lowest = 0.0;
    for (double t = 0.0;;) {
      const double hit = rays.hit(top, -Vec3::UnitZ(), t);
      if (!std::isfinite(hit)) break;
      const double z = top.z() - hit;
      if (z > kUndersideZ) lowest = z;
      t = hit + 1e-5;
    }
    model.footprint.value[i] = static_cast<float>(lowest);
  }

  // The nearest-sample tree (the continued faces ask it), the surface's and the samples' lookup grids.
  make_lookups(rest, s, model);
  beyond_edge_samples(rest, model, s);
}

}  // namespace weldtwin
