#include "core/part_outline.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {
namespace {

using Vec2 = Eigen::Vector2d;

double cross2(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
}

constexpr int kPadRimSamples = 8;          // points on the pad's rim checked for the face under it
constexpr double kSeamSampleStep = 0.005;  // seams checked every 5 mm [m]

// Whether the pad's disc centred at `xy` rests on one level face of the part; its height if so.
std::optional<double> pad_height(const Mesh& mesh, const Vec2& xy, const ClampSiteSettings& s) {
  const auto centre = surface_above(mesh, xy);
  if (!centre || centre->normal.z() < s.min_face_normal_z || centre->z_m < s.min_grip_height_m) return {};
  for (int k = 0; k < kPadRimSamples; ++k) {
    const double a = 2.0 * kPi * k / kPadRimSamples;
    const auto rim = surface_above(mesh, xy + ClampDims::kPadRadius * Vec2(std::cos(a), std::sin(a)));
    if (!rim || rim->normal.z() < s.min_face_normal_z || std::abs(rim->z_m - centre->z_m) > s.flatness_m)
      return {};
  }
  return centre->z_m;
}

}  // namespace

MeshBox mesh_box(const Mesh& mesh) {
  MeshBox box{Vec3::Constant(1e300), Vec3::Constant(-1e300)};
  for (const Vec3& v : mesh.vertices) {
    box.lo = box.lo.cwiseMin(v);
    box.hi = box.hi.cwiseMax(v);
  }
  return box;
}

std::vector<Vec2> convex_outline(const Mesh& mesh) {
  std::vector<Vec2> p;
  p.reserve(mesh.vertices.size());
  for (const Vec3& v : mesh.vertices) p.emplace_back(v.x(), v.y());
  std::sort(p.begin(), p.end(),
            [](const Vec2& a, const Vec2& b) { return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y()); });
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return p;
  // Monotone chain: the lower hull left to right, then the upper hull back; collinear points dropped.
  std::vector<Vec2> hull(2 * p.size());
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross2(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross2(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  hull.resize(k - 1);
  return hull;
}

std::optional<SurfaceAbove> surface_above(const Mesh& mesh, const Vec2& xy) {
  std::optional<SurfaceAbove> best;
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec2 a2 = a.head<2>(), b2 = b.head<2>(), c2 = c.head<2>();
    const double area = cross2(a2, b2, c2);
    if (std::abs(area) < 1e-14) continue;  // a vertical face: no height above a point
    const double wa = cross2(b2, c2, xy) / area, wb = cross2(c2, a2, xy) / area, wc = 1.0 - wa - wb;
    constexpr double kOnEdge = -1e-9;
    if (wa < kOnEdge || wb < kOnEdge || wc < kOnEdge) continue;
    const double z = wa * a.z() + wb * b.z() + wc * c.z();
    if (best && z <= best->z_m) continue;
    Vec3 n = (b - a).cross(c - a).normalized();
    if (n.z() < 0) n = -n;  // seen from above, whichever way the file turned the face
    best = SurfaceAbove{z, n};
  }
  return best;
}

std::vector<ClampSite> outline_clamp_sites(const Mesh& mesh, const std::vector<Vec2>& outline,
                                           const std::vector<Seam>& seams, const ClampSiteSettings& s) {
  struct Candidate {
    Vec2 xy, outward;
  };
  std::vector<Candidate> candidates;
  const size_t n = outline.size();
  if (n < 3) return {};
  for (size_t i = 0; i < n; ++i) {  // corners that turn left (convex), inset along the bisector
    const Vec2 &p = outline[(i + n - 1) % n], &v = outline[i], &q = outline[(i + 1) % n];
    if (cross2(p, v, q) <= 0) continue;
    const Vec2 e1 = (p - v).normalized(), e2 = (q - v).normalized();
    const Vec2 inward = (e1 + e2).normalized();
    const double half_angle = 0.5 * std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
    if (half_angle < 1e-3) continue;
    candidates.push_back({v + s.edge_clearance_m / std::sin(half_angle) * inward, -inward});
  }
  for (size_t i = 0; i < n; ++i) {  // the middles of the edges, inset along the inward normal
    const Vec2 &v = outline[i], &q = outline[(i + 1) % n];
    const Vec2 d = (q - v).normalized();
    const Vec2 inward(-d.y(), d.x());
    candidates.push_back({0.5 * (v + q) + s.edge_clearance_m * inward, -inward});
  }

  std::vector<Vec2> seam_xy;
  for (const Seam& seam : seams)
    for (int k = 0, m = static_cast<int>(seam.length_m() / kSeamSampleStep) + 1; k <= m; ++k)
      seam_xy.push_back(seam.point_at(static_cast<double>(k) / m).head<2>());

  std::vector<ClampSite> sites;
  for (const Candidate& c : candidates) {
    const bool near_seam = std::any_of(seam_xy.begin(), seam_xy.end(),
                                       [&](const Vec2& p) { return (p - c.xy).norm() < s.seam_clearance_m; });
    const bool near_site = std::any_of(sites.begin(), sites.end(), [&](const ClampSite& t) {
      return (t.grip.head<2>() - c.xy).norm() < 2.0 * ClampDims::kPadRadius;
    });
    if (near_seam || near_site) continue;
    if (const auto z = pad_height(mesh, c.xy, s)) sites.push_back({Vec3(c.xy.x(), c.xy.y(), *z), c.outward});
  }
  return sites;
}

}  // namespace weldtwin
