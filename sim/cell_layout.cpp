#include "sim/cell_layout.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "core/error.hpp"

namespace weldtwin {
namespace {

using Vec2 = Eigen::Vector2d;

bool on_table(const TableSpec& t, const Vec2& p, double margin = 0.0) {
  return p.x() >= t.x_min_m + margin && p.x() <= t.x_max_m - margin && p.y() >= t.y_min_m + margin &&
         p.y() <= t.y_max_m - margin;
}

Vec2 xy(const Vec3& p) {
  return p.head<2>();
}

// A circle that holds an object's footprint on the table, for overlap checks.
struct Disc {
  Vec2 c;
  double r;
};

std::vector<Disc> clamp_discs(const ClampPlacement& c) {
  const Vec2 o = xy(c.T_base_clamp.translation());
  const Vec2 out = xy(c.T_base_clamp.linear().col(0)).normalized();
  // The body from the base block to the handle tip; the arm over the part is not on the table.
  return {{o + out * 0.10, 0.045}, {o + out * 0.18, 0.05}};
}

Disc clutter_disc(const ClutterItem& item) {
  const double r =
      item.type == ClutterItem::Type::kBox ? 0.5 * item.size_m.head<2>().norm() : 0.5 * item.size_m.x();
  return {Vec2(item.x_m, item.y_m), r};
}

bool overlaps(const Disc& a, const Disc& b, double margin) {
  return (a.c - b.c).norm() < a.r + b.r + margin;
}

// Distance from p to the part's outline polygon (0 inside).
double distance_to_part(const PartSpec& part, const Iso3& T_base_part, const Vec2& p) {
  const Vec3 local3 = T_base_part.inverse() * Vec3(p.x(), p.y(), 0.0);
  const Vec2 q = local3.head<2>();
  const auto& fp = part.footprint;
  bool inside = false;
  double best = 1e9;
  for (size_t i = 0, j = fp.size() - 1; i < fp.size(); j = i++) {
    const Vec2 &a = fp[i], &b = fp[j];
    if ((a.y() > q.y()) != (b.y() > q.y()) &&
        q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
    const Vec2 ab = b - a;
    const double s = std::clamp((q - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + s * ab - q).norm());
  }
  return inside ? 0.0 : best;
}

ClampPlacement place_clamp(const PartSpec& part, const Iso3& T_base_part, int site) {
  const ClampSite& s = part.clamp_sites[static_cast<size_t>(site)];
  const Vec3 grip = T_base_part * s.grip;
  const Vec3 out = T_base_part.linear() * Vec3(s.outward.x(), s.outward.y(), 0.0);
  Mat3 R;
  R.col(0) = out.normalized();
  R.col(2) = Vec3::UnitZ();
  R.col(1) = R.col(2).cross(R.col(0));
  ClampPlacement c;
  c.site = site;
  c.T_base_clamp = make_transform(grip, R);
  c.grip_height_m = s.grip.z();  // the part frame's z = 0 rests on the table
  return c;
}

std::string part_problem(const CellSpec& cell, const PartSpec& part, const Iso3& T) {
  std::ostringstream why;
  const double z = T.translation().z() - cell.table.top_z_m;
  if (z < -1e-6) {
    why << "part intersects the table (z = " << z << " m below the top)";
    return why.str();
  }
  if (z > 1e-6) {
    why << "part floats " << z << " m above the table (it must rest on it)";
    return why.str();
  }
  if ((T.linear().col(2) - Vec3::UnitZ()).norm() > 1e-6)
    return "part must stand upright on the table (yaw only)";
  const PlacementSpec& pl = cell.placement;
  const bool ring = pl.area == PlacementSpec::Area::kRing;
  const double bearing = std::atan2(T.translation().y(), T.translation().x());
  if (ring && std::abs(bearing) > pl.max_bearing_rad + 1e-9) {
    why << "part is out of reach: bearing " << rad2deg(bearing) << " deg exceeds "
        << rad2deg(pl.max_bearing_rad);
    return why.str();
  }
  for (const Seam& s : part.seams) {
    for (int k = 0; ring && k <= 16; ++k) {
      const double r = xy(T * s.point_at(k / 16.0)).norm();
      if (r > pl.max_radius_m + 1e-9 || r < pl.min_radius_m - 1e-9) {
        why << "part is out of reach: seam '" << s.name << "' passes " << r
            << " m from the robot axis (reach " << pl.min_radius_m << "-" << pl.max_radius_m << " m)";
        return why.str();
      }
    }
  }
  for (const auto& p : part.footprint) {
    const Vec2 b = xy(T * Vec3(p.x(), p.y(), 0.0));
    if (!on_table(cell.table, b)) {
      why << "part hangs off the table at (" << b.x() << ", " << b.y() << ") m";
      return why.str();
    }
    if (b.norm() < cell.placement.base_keepout_m) return "part overlaps the robot base";
  }
  return "";
}

}  // namespace

std::string layout_problem(const CellSpec& cell, const PartSpec& part, const CellLayout& layout) {
  if (std::string p = part_problem(cell, part, layout.T_base_part); !p.empty()) return p;
  std::vector<Disc> taken;
  for (size_t i = 0; i < layout.clamps.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if ((layout.clamps[i].T_base_clamp.translation() - layout.clamps[j].T_base_clamp.translation()).norm() <
          2 * ClampDims::kPadRadius + 0.005)
        return "clamps at sites " + std::to_string(layout.clamps[j].site) + " and " +
               std::to_string(layout.clamps[i].site) + " press on the same spot";
  for (const auto& c : layout.clamps) {
    const Vec2 o = xy(c.T_base_clamp.translation());
    const Vec2 out = xy(c.T_base_clamp.linear().col(0));
    const Vec2 side(-out.y(), out.x());
    for (double a : {ClampDims::kBaseStart, ClampDims::kBaseEnd})
      for (double b : {-ClampDims::kHalfWidth, ClampDims::kHalfWidth})
        if (!on_table(cell.table, o + a * out + b * side))
          return "clamp at site " + std::to_string(c.site) + " stands off the table";
    for (const Disc& d : clamp_discs(c)) {
      for (const Disc& t : taken)
        if (overlaps(d, t, 0.0))
          return "clamps at site " + std::to_string(c.site) + " collide with another clamp";
      if (d.c.norm() < cell.placement.base_keepout_m + d.r) return "a clamp overlaps the robot base";
    }
    for (const Disc& d : clamp_discs(c)) taken.push_back(d);
  }
  for (size_t i = 0; i < layout.clutter.size(); ++i) {
    const Disc d = clutter_disc(layout.clutter[i]);
    const std::string name = "clutter item " + std::to_string(i);
    if (!on_table(cell.table, d.c, d.r)) return name + " stands off the table";
    if (d.c.norm() < cell.placement.base_keepout_m + d.r) return name + " overlaps the robot base";
    if (distance_to_part(part, layout.T_base_part, d.c) < d.r + 0.02) return name + " overlaps the part";
    for (const Disc& t : taken)
      if (overlaps(d, t, 0.01)) return name + " overlaps a clamp or other clutter";
    taken.push_back(d);
  }
  return "";
}

CellLayout layout_at(const CellSpec& cell, const PartSpec& part, const Iso3& T_base_part) {
  CellLayout layout;
  layout.T_base_part = T_base_part;
  for (int site : cell.clamp_sites) {
    if (site < 0 || site >= static_cast<int>(part.clamp_sites.size()))
      throw input_error(cell.source, "clamp site " + std::to_string(site) + " does not exist on part '" +
                                         part.name + "' (it has " + std::to_string(part.clamp_sites.size()) +
                                         ")");
    layout.clamps.push_back(place_clamp(part, layout.T_base_part, site));
  }
  layout.clutter = cell.clutter;
  return layout;
}

CellLayout make_layout(const CellSpec& cell, const PartSpec& part, std::optional<uint64_t> seed) {
  CellLayout layout;
  if (!seed) {
    if (!cell.part_pose)
      throw input_error(cell.source, "part has no pose (x_m, y_m): give one or pass --seed");
    const PartPose& p = *cell.part_pose;
    layout = layout_at(cell, part, planar_pose(p.x_m, p.y_m, cell.table.top_z_m + p.z_m, p.yaw_rad));
    if (std::string why = layout_problem(cell, part, layout); !why.empty())
      throw input_error(cell.source, why);
    return layout;
  }

  // Seeded draw: rejection sampling, each stage on its own until it fits.
  std::mt19937_64 rng(*seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  layout.seed = seed;
  const PlacementSpec& pl = cell.placement;
  std::vector<int> sites(part.clamp_sites.size());
  const int min_clamps = std::min<int>(2, static_cast<int>(sites.size()));
  bool placed = false;
  for (int attempt = 0; attempt < 20000 && !placed; ++attempt) {
    Vec2 at;
    if (pl.area == PlacementSpec::Area::kRing) {  // uniform over the ring sector by area
      const double r =
          std::sqrt(pl.min_radius_m * pl.min_radius_m +
                    u01(rng) * (pl.max_radius_m * pl.max_radius_m - pl.min_radius_m * pl.min_radius_m));
      const double bearing = (2.0 * u01(rng) - 1.0) * pl.max_bearing_rad;
      at = Vec2(r * std::cos(bearing), r * std::sin(bearing));
    } else {  // uniform over the table top
      const TableSpec& t = cell.table;
      at = Vec2(t.x_min_m + (t.x_max_m - t.x_min_m) * u01(rng),
                t.y_min_m + (t.y_max_m - t.y_min_m) * u01(rng));
    }
    const double yaw = 2.0 * kPi * u01(rng);
    layout.T_base_part = planar_pose(at.x(), at.y(), cell.table.top_z_m, yaw);
    if (!part_problem(cell, part, layout.T_base_part).empty()) continue;
    // 2-4 clamps on sites that fit (on the table, clear of each other and the robot); else another pose.
    for (size_t i = 0; i < sites.size(); ++i) sites[i] = static_cast<int>(i);
    std::shuffle(sites.begin(), sites.end(), rng);
    const int wanted = std::min<int>(2 + static_cast<int>(rng() % 3), static_cast<int>(sites.size()));
    layout.clamps.clear();
    for (int site : sites) {
      if (static_cast<int>(layout.clamps.size()) == wanted) break;
      layout.clamps.push_back(place_clamp(part, layout.T_base_part, site));
      if (!layout_problem(cell, part, layout).empty()) layout.clamps.pop_back();
    }
    placed = static_cast<int>(layout.clamps.size()) >= min_clamps;
  }
  if (!placed) throw input_error(cell.source, "no pose of part '" + part.name + "' fits the placement area");

  const int clutter_wanted = static_cast<int>(rng() % 4);
  for (int attempt = 0; attempt < 400 && static_cast<int>(layout.clutter.size()) < clutter_wanted;
       ++attempt) {
    ClutterItem item;
    item.type = u01(rng) < 0.6 ? ClutterItem::Type::kBox : ClutterItem::Type::kCylinder;
    if (item.type == ClutterItem::Type::kBox) {
      item.size_m = Vec3(0.04 + 0.12 * u01(rng), 0.03 + 0.08 * u01(rng), 0.01 + 0.07 * u01(rng));
    } else {
      const double d = 0.03 + 0.06 * u01(rng);
      item.size_m = Vec3(d, d, 0.03 + 0.12 * u01(rng));
    }
    item.x_m = cell.table.x_min_m + (cell.table.x_max_m - cell.table.x_min_m) * u01(rng);
    item.y_m = cell.table.y_min_m + (cell.table.y_max_m - cell.table.y_min_m) * u01(rng);
    item.yaw_rad = 2.0 * kPi * u01(rng);
    layout.clutter.push_back(item);
    if (!layout_problem(cell, part, layout).empty()) layout.clutter.pop_back();
  }
  return layout;
}

}  // namespace weldtwin
