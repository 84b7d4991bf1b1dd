#include "sim/part_deviation.hpp"

#include <cmath>
#include <cstdio>
#include <random>

namespace weldtwin {
namespace {

// A closed cube of edge e centred on c, faces wound outwards.
void add_cube(Mesh& mesh, const Vec3& c, double e) {
  const int base = static_cast<int>(mesh.vertices.size());
  for (int k = 0; k < 8; ++k)
    mesh.vertices.push_back(c + 0.5 * e * Vec3(k & 1 ? 1 : -1, k & 2 ? 1 : -1, k & 4 ? 1 : -1));
  // Corners by bits (x, y, z); two triangles per face, counter-clockwise seen from outside.
  static const int kFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                    {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& f : kFaces) mesh.faces.emplace_back(base + f[0], base + f[1], base + f[2]);
}

}  // namespace

std::string DeviatedPart::describe() const {
  char buf[200];
  std::snprintf(buf, sizeof buf, "extents x%.4f x%.4f x%.4f, %zu tack welds, bent %.2f deg along %s",
                scale.x(), scale.y(), scale.z(), tacks.size(), bend_rad * 180.0 / kPi,
                bend_axis == 0 ? "x" : "y");
  return buf;
}

DeviatedPart deviate_part(const Mesh& cad, const std::vector<Vec3>& seam_points,
                          const PartDeviationSetting& s, uint64_t seed) {
  DeviatedPart out;
  out.mesh = cad;
  std::mt19937_64 rng(seed * 0x2545F4914F6CDD1DULL + 29);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const Vec3& v : cad.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const Vec3 ext = hi - lo, centre = 0.5 * (lo + hi);
  // Extents: the first draws, as the survey drew them before tacks and bends existed.
  for (int k = 0; k < 3; ++k) out.scale[k] = (ext[k] + s.dimension_m * (2.0 * u01(rng) - 1.0)) / ext[k];
  for (int i = 0; i < s.tack_welds && !seam_points.empty(); ++i) {
    const size_t k = std::min(seam_points.size() - 1, static_cast<size_t>(u01(rng) * seam_points.size()));
    out.tacks.push_back(seam_points[k]);
    add_cube(out.mesh, seam_points[k], s.tack_edge_m);
  }
  out.bend_axis = ext.x() >= ext.y() ? 0 : 1;
  out.bend_rad = s.bend_deg * kPi / 180.0 * (2.0 * u01(rng) - 1.0);
  const double length = ext[out.bend_axis];
  out.curvature = length > 0.0 ? out.bend_rad / length : 0.0;  // the angle spread over the length
  out.centre = centre;
  out.floor_z = lo.z();
  for (Vec3& v : out.mesh.vertices) v = out.apply(v);
  return out;
}

Vec3 DeviatedPart::apply(const Vec3& v) const {
  Vec3 p = centre + (v - centre).cwiseProduct(scale);
  p.z() = floor_z + (v.z() - floor_z) * scale.z();  // it still rests on its lowest face
  // A circular arc of small angle: the offset across grows with the square of the distance from the middle.
  const double along = p[bend_axis] - centre[bend_axis];
  p[1 - bend_axis] += 0.5 * curvature * along * along;
  return p;
}

}  // namespace weldtwin
