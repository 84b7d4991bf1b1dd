#include "sim/seam_coverage.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {

std::vector<SeamCoverage> seam_coverage(const PartSpec& part, const Iso3& T_base_part,
                                        const std::vector<Vec3>& part_points_base, const CoverageSetting& s) {
  // Work in the part frame.
  const Iso3 T_part_base = T_base_part.inverse();
  std::vector<Vec3> pts;
  pts.reserve(part_points_base.size());
  for (const Vec3& p : part_points_base) pts.push_back(T_part_base * p);

  std::vector<SeamCoverage> out;
  for (const Seam& seam : part.seams) {
    SeamCoverage c;
    c.seam = seam.name;
    const double len = seam.length_m();
    const int n =
        std::max(1, static_cast<int>(std::floor((len - 2 * s.end_margin_m) / s.station_step_m)) + 1);
    std::vector<char> near_seam(pts.size(), 0);
    for (int k = 0; k < n; ++k) {
      const double f = (s.end_margin_m + k * s.station_step_m) / len;
      const Vec3 x = seam.point_at(std::min(f, 1.0));
      const Vec3 d = seam.direction_at(f);
      // n and m made orthogonal to the travel direction, as the torch convention does.
      const Vec3 nn = (seam.normal - seam.normal.dot(d) * d).normalized();
      const Vec3 wall = seam.wall_normal_at(f);
      const Vec3 mm = (wall - wall.dot(d) * d).normalized();
      bool on_reference = false, on_wall = false;
      for (size_t i = 0; i < pts.size(); ++i) {
        const Vec3 v = pts[i] - x;
        if (v.squaredNorm() > s.radius_m * s.radius_m) continue;
        near_seam[i] = 1;
        const double a = v.dot(nn), b = v.dot(mm);
        if (std::abs(a) < s.on_surface_m && b > 0.0) on_reference = true;
        if (std::abs(b) < s.on_surface_m && a > 0.0) on_wall = true;
      }
      ++c.stations;
      c.seen += on_reference && on_wall;
      c.seen_one += on_reference || on_wall;
    }
    c.points_near = static_cast<int>(std::count(near_seam.begin(), near_seam.end(), 1));
    out.push_back(c);
  }
  return out;
}

}  // namespace weldtwin
