#include "core/part_spec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/mesh_file.hpp"
#include "core/part_outline.hpp"
#include "core/yaml_util.hpp"

namespace weldtwin {
namespace {

constexpr double kMinSpeed = 0.5e-3;         // slower than any weld travels [m/s]
constexpr double kMaxSpeed = 0.2;            // faster than any arc weld travels [m/s]
constexpr double kMaxTravelAngle = kPi / 4;  // [rad]
constexpr double kBaseTolerance = 0.5e-3;    // the mesh's base at z = 0, its top at the height given [m]
constexpr double kSeamMargin = 0.02;         // a seam's points at most this far outside the mesh's box [m]
constexpr int kSeamChecks = 64;              // points checked along each seam
// A weld tolerance is tenths of a millimetre to millimetres: below what the range noise allows no scan is
// ever accepted, above a fillet's leg the torch misses the joint.
constexpr double kMinWeldToleranceMm = 0.1, kMaxWeldToleranceMm = 5.0;

std::string mm(double m) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f mm", m * 1e3);
  return buf;
}

}  // namespace

double Seam::length_m() const {
  return kind == Kind::kLine ? (end - start).norm() : radius_m * std::abs(sweep_rad);
}

Vec3 Seam::point_at(double s) const {
  if (kind == Kind::kLine) return start + s * (end - start);
  const Vec3 r0 = start - center;
  return center + Eigen::AngleAxisd(s * sweep_rad, axis) * r0;
}

Vec3 Seam::direction_at(double s) const {
  return frame_at(s).direction;
}

Vec3 Seam::wall_normal_at(double s) const {
  return frame_at(s).wall_normal;
}

Seam::Frame Seam::frame_at(double s) const {
  Frame f;
  f.point = point_at(s);
  if (kind == Kind::kLine) {
    f.direction = (end - start).normalized();
  } else {
    const Vec3 r = f.point - center;
    f.direction = (sweep_rad >= 0 ? 1.0 : -1.0) * axis.cross(r).normalized();
  }
  if (wall_normal_radial) {
    const Vec3 r = f.point - center;
    f.wall_normal = (r - r.dot(axis) * axis).normalized();
  } else {
    f.wall_normal = wall_normal;
  }
  return f;
}

double Seam::distance_to(const Vec3& q) const {
  if (kind == Kind::kLine) {
    const Vec3 ab = end - start;
    const double len2 = ab.squaredNorm();
    const double u = len2 > 0 ? std::clamp((q - start).dot(ab) / len2, 0.0, 1.0) : 0.0;
    return (start + u * ab - q).norm();
  }
  // An arc: the nearest point is on the circle in the direction of q (about the axis) when that direction
  // lies within the sweep, else an end.
  const Vec3 w = axis.normalized(), r0 = start - center;
  const Vec3 v = q - center;
  const double h = v.dot(w);
  const Vec3 radial = v - h * w;
  const double ends = std::min((q - start).norm(), (q - point_at(1.0)).norm());
  if (radial.norm() < 1e-12) return std::min(ends, std::hypot(h, radius_m));  // on the axis: all alike
  const double sign = sweep_rad >= 0 ? 1.0 : -1.0;
  double angle =
      sign * std::atan2(w.dot(r0.cross(radial)), r0.dot(radial));  // from the start, in sweep sense
  if (angle < 0) angle += 2 * kPi;
  if (angle <= std::abs(sweep_rad)) return std::min(ends, std::hypot(h, radial.norm() - radius_m));
  return ends;
}

Seam Seam::reversed() const {
  Seam r = *this;
  r.start = point_at(1.0);
  if (kind == Kind::kLine) {
    r.end = start;
  } else {
    r.sweep_rad = -sweep_rad;  // about the same axis and centre, back from the end
  }
  return r;
}

double PartSpec::footprint_radius_m() const {
  double r = 0.0;
  for (const auto& p : footprint) r = std::max(r, p.norm());
  return r;
}

std::vector<Vec3> PartSpec::seam_points(double spacing_m) const {
  std::vector<Vec3> out;
  for (const Seam& seam : seams)
    for (int k = 0, n = static_cast<int>(seam.length_m() / spacing_m) + 1; k <= n; ++k)
      out.push_back(seam.point_at(static_cast<double>(k) / n));
  return out;
}

namespace {

Seam parse_seam(const YAML::Node& node, size_t index, const std::string& file) {
  Seam s;
  s.name = node["name"] ? yaml::text(node, "name", file) : "seam" + std::to_string(index);
  const std::string where = "seam '" + s.name + "': ";
  s.start = yaml::vec3(node, "start", file);
  if (node["center"]) {
    s.kind = Seam::Kind::kArc;
    s.center = yaml::vec3(node, "center", file);
    s.axis = yaml::vec3(node, "axis", file);
    if (!s.axis.allFinite() || s.axis.stableNorm() < 1e-9) throw input_error(file, where + "zero arc axis");
    s.axis.stableNormalize();
    s.sweep_rad = yaml::angle(node, "sweep", file);
    if (!(std::abs(s.sweep_rad) <= 2 * kPi + 1e-9))
      throw input_error(file, where + "sweep_deg must be within -360 and +360 (once around at most)");
    const Vec3 r = s.start - s.center;
    s.radius_m = (r - r.dot(s.axis) * s.axis).norm();
    if (std::abs(r.dot(s.axis)) > 1e-6) throw input_error(file, where + "start is not in the arc's plane");
    if (auto given = yaml::maybe_length(node, "radius", file); given && std::abs(*given - s.radius_m) > 1e-6)
      throw input_error(file, where + "radius does not match |start - center|");
  } else {
    s.end = yaml::vec3(node, "end", file);
  }
  if (s.length_m() < 1e-4) throw input_error(file, where + "zero-length seam");
  s.normal = yaml::vec3(node, "normal", file);
  if (!s.normal.allFinite() || s.normal.stableNorm() < 1e-9)
    throw input_error(file, where + "normal must be a finite, non-zero direction");
  s.normal.stableNormalize();
  if (node["wall_normal"] && node["wall_normal"].IsScalar() && node["wall_normal"].Scalar() == "radial") {
    if (s.kind != Seam::Kind::kArc) throw input_error(file, where + "wall_normal 'radial' needs an arc seam");
    s.wall_normal_radial = true;
  } else {
    s.wall_normal = yaml::vec3(node, "wall_normal", file);
    if (!s.wall_normal.allFinite() || s.wall_normal.stableNorm() < 1e-9)
      throw input_error(file, where + "wall_normal must be a finite, non-zero direction");
    s.wall_normal.stableNormalize();
  }
  // n and m are made orthogonal to the travel direction by the planner; they must not be parallel to it.
  for (double f : {0.0, 0.5, 1.0}) {
    const Vec3 d = s.direction_at(f);
    if (std::abs(d.dot(s.normal)) > 0.999)
      throw input_error(file, where + "normal is parallel to the travel direction");
    if (std::abs(d.dot(s.wall_normal_at(f))) > 0.999)
      throw input_error(file, where + "wall_normal is parallel to the travel direction");
  }
  s.work_angle_rad = yaml::angle(node, "work_angle", file);
  s.travel_angle_rad = yaml::angle(node, "travel_angle", file);
  // The torch points into the joint between the two members: a work angle outside 0-90 deg points it into
  // one of them, a travel angle beyond 45 deg lays it along the seam.
  if (!(s.work_angle_rad >= 0.0 && s.work_angle_rad <= kPi / 2))
    throw input_error(file, where + "work_angle_deg must be within 0-90 (the torch between the members)");
  if (!(std::abs(s.travel_angle_rad) <= kMaxTravelAngle))
    throw input_error(file, where + "travel_angle_deg must be within -45 and +45");
  s.work_angle_tol_rad = yaml::maybe_angle(node, "work_angle_tol", file).value_or(0.0);
  if (!(s.work_angle_tol_rad >= 0.0 && s.work_angle_rad - s.work_angle_tol_rad >= -1e-12 &&
        s.work_angle_rad + s.work_angle_tol_rad <= kPi / 2 + 1e-12))
    throw input_error(file, where + "work_angle_deg +- work_angle_tol_deg must stay within 0-90");
  s.travel_angle_min_rad = yaml::maybe_angle(node, "travel_angle_min", file).value_or(s.travel_angle_rad);
  s.travel_angle_max_rad = yaml::maybe_angle(node, "travel_angle_max", file).value_or(s.travel_angle_rad);
  if (!(s.travel_angle_min_rad <= s.travel_angle_rad + 1e-12 &&
        s.travel_angle_rad <= s.travel_angle_max_rad + 1e-12 && s.travel_angle_min_rad >= -kMaxTravelAngle &&
        s.travel_angle_max_rad <= kMaxTravelAngle))
    throw input_error(file, where +
                                "travel_angle_min_deg <= travel_angle_deg <= travel_angle_max_deg, "
                                "all within -45 and +45");
  if (node["torch_roll_deg"] && node["torch_roll_deg"].IsScalar() &&
      node["torch_roll_deg"].Scalar() == "free") {
    s.torch_roll_rad.reset();
  } else {
    s.torch_roll_rad = yaml::angle(node, "torch_roll", file);
  }
  if (auto v = yaml::maybe_number(node, "speed_mm_s", file)) {
    s.speed_m_s = *v * 1e-3;
  } else {
    s.speed_m_s = yaml::number(node, "speed_m_s", file);
  }
  if (!(s.speed_m_s >= kMinSpeed && s.speed_m_s <= kMaxSpeed))
    throw input_error(file, where + "speed_mm_s must be within 0.5-200 (welding travel speeds)");
  return s;
}

}  // namespace

PartSpec PartSpec::load(const std::string& yaml_path) {
  try {
    return parse(yaml_path);
  } catch (const YAML::Exception& e) {
    throw input_error(yaml_path, "malformed part spec: " + e.msg);
  }
}

PartSpec PartSpec::parse(const std::string& yaml_path) {
  const YAML::Node root = yaml::load_file(yaml_path);
  PartSpec part;
  part.source = yaml_path;
  part.name = yaml::text(root, "name", yaml_path);
  part.mesh_path = yaml::resolve(yaml_path, yaml::text(root, "model", yaml_path));
  if (!is_file(part.mesh_path)) throw input_error(yaml_path, "mesh '" + part.mesh_path + "' does not exist");
  const Mesh mesh = load_mesh(part.mesh_path);
  const MeshBox box = mesh_box(mesh);
  if (std::abs(box.lo.z()) > kBaseTolerance)
    throw input_error(yaml_path, "the mesh's lowest point is at z = " + mm(box.lo.z()) +
                                     " in the part frame, whose z = 0 rests on the table: move the mesh's "
                                     "origin (and the seams) to the part's base");
  const auto given_height = yaml::maybe_length(root, "height", yaml_path);
  if (given_height && std::abs(*given_height - box.hi.z()) > kBaseTolerance)
    throw input_error(yaml_path,
                      "height " + mm(*given_height) + " but the mesh reaches " + mm(box.hi.z()) +
                          " above the table: correct it or leave it out (it is taken from the mesh)");
  part.height_m = given_height.value_or(box.hi.z());
  if (const auto tol_mm = yaml::maybe_number(root, "weld_tolerance_mm", yaml_path)) {
    if (!(*tol_mm >= kMinWeldToleranceMm && *tol_mm <= kMaxWeldToleranceMm))
      throw input_error(yaml_path, "weld_tolerance_mm " + mm(1e-3 * *tol_mm) + " is not between " +
                                       mm(1e-3 * kMinWeldToleranceMm) + " and " +
                                       mm(1e-3 * kMaxWeldToleranceMm) +
                                       " (the weld must land this close to "
                                       "the seam)");
    part.weld_tolerance_m = 1e-3 * *tol_mm;
  }

  if (const YAML::Node fp = root["footprint_m"]) {
    if (!fp.IsSequence() || fp.size() < 3)
      throw input_error(yaml_path,
                        "field 'footprint_m' must list at least 3 points [x, y] (or be left out: "
                        "it is taken from the mesh)");
    for (const auto& p : fp) {
      if (!p.IsSequence() || p.size() != 2) throw input_error(yaml_path, "footprint_m points must be [x, y]");
      part.footprint.emplace_back(p[0].as<double>(), p[1].as<double>());
      if (!part.footprint.back().allFinite()) throw input_error(yaml_path, "footprint_m point is not finite");
    }
  } else {
    part.footprint = convex_outline(mesh);
    if (part.footprint.size() < 3) throw input_error(yaml_path, "the mesh has no outline seen from above");
  }

  if (const YAML::Node sites = root["clamp_sites"]) {  // given, maybe empty: a part held without clamps
    for (const auto& s : sites) {
      ClampSite c;
      c.grip = yaml::vec3(s, "grip", yaml_path);
      auto o = yaml::numbers(s, "outward", 2, yaml_path);
      c.outward = Eigen::Vector2d(o[0], o[1]);
      if (!c.outward.allFinite() || c.outward.stableNorm() < 1e-9)
        throw input_error(yaml_path, "clamp site with a zero outward direction");
      c.outward.stableNormalize();
      part.clamp_sites.push_back(c);
    }
  }

  const YAML::Node seams = root["seams"];
  if (!seams || !seams.IsSequence() || seams.size() == 0)
    throw input_error(yaml_path, "field 'seams' must list at least one seam");
  constexpr size_t kMaxSeams = 200;  // a part welded in one clamping has tens of seams, not thousands
  if (seams.size() > kMaxSeams)
    throw input_error(yaml_path, "field 'seams' lists " + std::to_string(seams.size()) + " seams; at most " +
                                     std::to_string(kMaxSeams) + " are welded in one clamping");
  for (size_t i = 0; i < seams.size(); ++i) part.seams.push_back(parse_seam(seams[i], i, yaml_path));
  // Every seam on the part: its points within the mesh's box and a margin (a seam elsewhere is a typing
  // error, and one kilometres long would be sampled millimetre by millimetre downstream).
  const Vec3 lo = box.lo - Vec3::Constant(kSeamMargin), hi = box.hi + Vec3::Constant(kSeamMargin);
  for (const Seam& seam : part.seams)
    for (int k = 0; k <= kSeamChecks; ++k) {
      const Vec3 p = seam.point_at(static_cast<double>(k) / kSeamChecks);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any())
        throw input_error(yaml_path, "seam '" + seam.name + "' leaves the part: it passes through (" +
                                         mm(p.x()) + ", " + mm(p.y()) + ", " + mm(p.z()) + "), more than " +
                                         mm(kSeamMargin) + " outside the mesh's box");
    }
  if (!root["clamp_sites"]) part.clamp_sites = outline_clamp_sites(mesh, part.footprint, part.seams);
  return part;
}

}  // namespace weldtwin
