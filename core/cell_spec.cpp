#include "core/cell_spec.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/yaml_util.hpp"

namespace weldtwin {
namespace {

// `relative` (field `key` of `file`) resolved against the file's folder; it must name a file.
std::string existing_file(const std::string& file, const std::string& key, const std::string& relative) {
  const std::string path = yaml::resolve(file, relative);
  if (!is_file(path)) throw input_error(file, "field '" + key + "': file '" + path + "' does not exist");
  return path;
}

std::string existing(const std::string& file, const YAML::Node& root, const std::string& key) {
  return existing_file(file, key, yaml::text(root, key, file));
}

// A length vector from KEY_m, KEY_mm or KEY (metres); zero when none is given.
Vec3 maybe_length3(const YAML::Node& node, const std::string& key, const std::string& file) {
  Vec3 v = Vec3::Zero();
  if (node[key + "_mm"]) v = 1e-3 * yaml::vec3(node, key + "_mm", file);
  if (node[key + "_m"]) v = yaml::vec3(node, key + "_m", file);
  if (node[key]) v = yaml::vec3(node, key, file);
  if (!(v.norm() < 100.0)) throw input_error(file, "field '" + key + "' lies 100 m or more away");
  return v;
}

// A frame: xyz_m (or xyz_mm) and rpy_deg (or rpy_rad), both optional.
UrdfOrigin maybe_origin(const YAML::Node& node, const std::string& file) {
  UrdfOrigin o;
  o.xyz_m = maybe_length3(node, "xyz", file);
  if (node["rpy_deg"]) o.rpy_rad = yaml::vec3(node, "rpy_deg", file) * (kPi / 180.0);
  if (node["rpy_rad"]) o.rpy_rad = yaml::vec3(node, "rpy_rad", file);
  if (!(o.rpy_rad.cwiseAbs().maxCoeff() <= 100.0)) throw input_error(file, "field 'rpy' is out of range");
  return o;
}

// Names end up in URDF and MJCF text: letters, digits, '_', '-' and '.' only.
std::string link_name(const YAML::Node& node, const std::string& key, const std::string& file) {
  const std::string name = yaml::text(node, key, file);
  const bool ok = !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  if (!ok)
    throw input_error(file, "tooling: '" + key + "' must be 1-64 letters, digits, '_', '-' or '.', got '" +
                                name.substr(0, 64) + "'");
  return name;
}

ToolingShape tooling_shape(const YAML::Node& s, const std::string& file, const std::string& link) {
  const std::string where = "tooling link '" + link + "': ";
  if (!s.IsMap()) throw input_error(file, where + "each shape must be a mapping");
  ToolingShape g;
  const std::string type = yaml::text(s, "type", file);
  Vec3 positive;  // the sizes that must be positive
  if (type == "box") {
    g.type = LinkGeometry::Type::kBox;
    g.size_m = positive = maybe_length3(s, "size", file);
  } else if (type == "cylinder") {
    g.type = LinkGeometry::Type::kCylinder;
    g.size_m = Vec3(yaml::length(s, "radius", file), yaml::length(s, "length", file), 0.0);
    positive = Vec3(g.size_m.x(), g.size_m.y(), 1.0);
  } else if (type == "sphere") {
    g.type = LinkGeometry::Type::kSphere;
    g.size_m = Vec3(yaml::length(s, "radius", file), 0.0, 0.0);
    positive = Vec3(g.size_m.x(), 1.0, 1.0);
  } else {
    throw input_error(file, where + "shape type must be 'box', 'cylinder' or 'sphere', got '" + type + "'");
  }
  if (!(positive.array() > 0.0).all() || !(positive.array() < 10.0).all())
    throw input_error(file, where + "shape sizes must be above 0 and below 10 m");
  g.origin = maybe_origin(s, file);
  if (s["rgba"]) {
    const std::vector<double> c = yaml::numbers(s, "rgba", 4, file);
    for (int k = 0; k < 4; ++k) {
      if (!(c[static_cast<size_t>(k)] >= 0.0 && c[static_cast<size_t>(k)] <= 1.0))
        throw input_error(file, where + "rgba values must lie in [0, 1]");
      g.rgba[k] = c[static_cast<size_t>(k)];
    }
  }
  return g;
}

// urdf: PATH and package_dirs: [DIR, ...] of a robot mapping (in a cell or a robot file).
void parse_urdf_ref(const YAML::Node& robot, const std::string& file, CellSpec& cell) {
  cell.robot_urdf = existing(file, robot, "urdf");
  if (const YAML::Node dirs = robot["package_dirs"]) {
    if (!dirs.IsSequence()) throw input_error(file, "robot: 'package_dirs' must list folders");
    for (const auto& d : dirs) {
      if (!d.IsScalar()) throw input_error(file, "robot: 'package_dirs' must list folders");
      const std::string dir = yaml::resolve(file, d.Scalar());
      if (!std::filesystem::is_directory(dir))
        throw input_error(file, "robot: package folder '" + dir + "' does not exist");
      cell.robot_package_dirs.push_back(dir);
    }
  }
}

// Tooling links, appended to the cell's.
void parse_tooling(const YAML::Node& tooling, const std::string& file, CellSpec& cell) {
  if (!tooling) return;
  if (!tooling.IsSequence()) throw input_error(file, "field 'tooling' must list links");
  constexpr size_t kMaxLinks = 64, kMaxShapes = 64;
  if (cell.tooling.size() + tooling.size() > kMaxLinks)
    throw input_error(file, "tooling: more than 64 links");
  for (const auto& t : tooling) {
    if (!t.IsMap()) throw input_error(file, "tooling: each link must be a mapping (link, parent, ...)");
    ToolingLink link;
    link.link = link_name(t, "link", file);
    link.parent = link_name(t, "parent", file);
    link.origin = maybe_origin(t, file);
    link.mass_kg = yaml::maybe_number(t, "mass_kg", file).value_or(0.0);
    if (!(link.mass_kg >= 0.0 && link.mass_kg < 100.0))
      throw input_error(file, "tooling link '" + link.link + "': mass_kg must lie in [0, 100)");
    if (const YAML::Node shapes = t["shapes"]) {
      if (!shapes.IsSequence() || shapes.size() > kMaxShapes)
        throw input_error(file, "tooling link '" + link.link + "': 'shapes' must list at most 64 shapes");
      for (const auto& s : shapes) link.shapes.push_back(tooling_shape(s, file, link.link));
    }
    cell.tooling.push_back(std::move(link));
  }
}

bool is_yaml_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".yaml" || ext == ".yml";
}

// A robot file: urdf, package_dirs, tooling (paths relative to it).
void parse_robot_file(const std::string& path, CellSpec& cell) {
  const YAML::Node robot_file = yaml::load_file(path);
  if (!robot_file.IsMap()) throw input_error(path, "a robot file is a mapping: urdf, package_dirs, tooling");
  parse_urdf_ref(robot_file, path, cell);
  parse_tooling(robot_file["tooling"], path, cell);
}

// The robot: a URDF path; {urdf: PATH, package_dirs: [DIR, ...]}; or a robot file (YAML: urdf, package_dirs,
// tooling; paths relative to it) that cells share. Then the tooling the cell itself adds.
void parse_robot(const YAML::Node& root, const std::string& file, CellSpec& cell) {
  const YAML::Node robot = root["robot"];
  if (robot && robot.IsMap()) {
    parse_urdf_ref(robot, file, cell);
  } else {
    const std::string path = existing(file, root, "robot");
    if (is_yaml_path(path)) {
      parse_robot_file(path, cell);
    } else {
      cell.robot_urdf = path;
    }
  }
  parse_tooling(root["tooling"], file, cell);
}

CellSpec parse(const std::string& file) {
  const YAML::Node root = yaml::load_file(file);
  CellSpec cell;
  cell.source = file;
  cell.name = root["name"] ? yaml::text(root, "name", file) : std::filesystem::path(file).stem().string();
  cell.environment_mjcf = existing(file, root, "environment");
  parse_robot(root, file, cell);
  cell.sweep_program = existing(file, root, "sweep");
  if (const YAML::Node r = root["rescan"]) {
    if (r.IsScalar()) {
      cell.rescan_programs.push_back(existing(file, root, "rescan"));
    } else {
      constexpr size_t kMaxRescans = 8;
      if (!r.IsSequence() || r.size() > kMaxRescans)
        throw input_error(
            file, "field 'rescan' must name a sweep program, or list at most " + std::to_string(kMaxRescans));
      for (const auto& item : r) {
        if (!item.IsScalar()) throw input_error(file, "field 'rescan' must list sweep program files");
        cell.rescan_programs.push_back(existing_file(file, "rescan", item.Scalar()));
      }
    }
  }

  if (const YAML::Node t = root["table"]) {
    cell.table.x_min_m = yaml::length(t, "x_min", file);
    cell.table.x_max_m = yaml::length(t, "x_max", file);
    cell.table.y_min_m = yaml::length(t, "y_min", file);
    cell.table.y_max_m = yaml::length(t, "y_max", file);
    cell.table.top_z_m = yaml::maybe_length(t, "top_z", file).value_or(0.0);
    if (cell.table.x_min_m >= cell.table.x_max_m || cell.table.y_min_m >= cell.table.y_max_m)
      throw input_error(file, "table: min must be below max");
  }
  if (const YAML::Node p = root["placement"]) {
    PlacementSpec& pl = cell.placement;
    pl.min_radius_m = yaml::maybe_length(p, "min_radius", file).value_or(pl.min_radius_m);
    pl.max_radius_m = yaml::maybe_length(p, "max_radius", file).value_or(pl.max_radius_m);
    pl.max_bearing_rad = yaml::maybe_angle(p, "max_bearing", file).value_or(pl.max_bearing_rad);
    pl.base_keepout_m = yaml::maybe_length(p, "base_keepout", file).value_or(pl.base_keepout_m);
    if (p["area"]) {
      const auto area = placement_area_from(yaml::text(p, "area", file));
      if (!area) throw input_error(file, "placement: area must be 'ring' or 'table'");
      pl.area = *area;
    }
    if (pl.min_radius_m >= pl.max_radius_m)
      throw input_error(file, "placement: min_radius must be below max_radius");
  }

  const YAML::Node part = root["part"];
  if (!part || !part.IsMap()) throw input_error(file, "missing section 'part'");
  cell.part_spec = existing(file, part, "spec");
  const bool has_x = static_cast<bool>(yaml::maybe_length(part, "x", file));
  const bool has_y = static_cast<bool>(yaml::maybe_length(part, "y", file));
  if (has_x != has_y)
    throw input_error(file, "part: give both x and y, or neither (then --seed draws the pose)");
  if (has_x) {
    PartPose pose;
    pose.x_m = yaml::length(part, "x", file);
    pose.y_m = yaml::length(part, "y", file);
    pose.z_m = yaml::maybe_length(part, "z", file).value_or(0.0);
    pose.yaw_rad = yaml::maybe_angle(part, "yaw", file).value_or(0.0);
    cell.part_pose = pose;
  }

  if (const YAML::Node clamps = root["clamps"]) {
    if (!clamps.IsSequence()) throw input_error(file, "field 'clamps' must list clamp site indices");
    for (const auto& c : clamps) cell.clamp_sites.push_back(c.as<int>());
  }
  if (const YAML::Node clutter = root["clutter"]) {
    for (const auto& c : clutter) {
      ClutterItem item;
      const std::string type = yaml::text(c, "type", file);
      if (type == "box") {
        item.type = ClutterItem::Type::kBox;
      } else if (type == "cylinder") {
        item.type = ClutterItem::Type::kCylinder;
      } else {
        throw input_error(file, "clutter type must be 'box' or 'cylinder', got '" + type + "'");
      }
      auto mm = yaml::numbers(c, "size_mm", 3, file);
      item.size_m = Vec3(mm[0], mm[1], mm[2]) * 1e-3;
      if ((item.size_m.array() <= 0.0).any()) throw input_error(file, "clutter sizes must be positive");
      item.x_m = yaml::length(c, "x", file);
      item.y_m = yaml::length(c, "y", file);
      item.yaw_rad = yaml::maybe_angle(c, "yaw", file).value_or(0.0);
      cell.clutter.push_back(item);
    }
  }
  if (const YAML::Node lidar = root["lidar"]) {
    if (!lidar.IsMap()) throw input_error(file, "field 'lidar' must be a mapping of setting: value");
    for (const auto& kv : lidar) {
      const std::string key = kv.first.as<std::string>();
      const std::string v = kv.second.Scalar();
      if (v == "true" || v == "false") {
        cell.lidar_overrides[key] = v == "true" ? 1.0 : 0.0;
      } else {
        cell.lidar_overrides[key] = yaml::number(lidar, key, file);
      }
    }
  }
  return cell;
}

}  // namespace

std::optional<PlacementSpec::Area> placement_area_from(const std::string& name) {
  if (name == "ring") return PlacementSpec::Area::kRing;
  if (name == "table") return PlacementSpec::Area::kTable;
  return std::nullopt;
}

const char* placement_area_name(PlacementSpec::Area area) {
  return area == PlacementSpec::Area::kTable ? "table" : "ring";
}

CellSpec CellSpec::load(const std::string& yaml_path) {
  try {
    return parse(yaml_path);
  } catch (const YAML::Exception& e) {
    throw input_error(yaml_path, "malformed cell: " + e.msg);
  }
}

void CellSpec::use_robot_file(const std::string& robot_yaml) {
  if (!is_yaml_path(robot_yaml) || !std::filesystem::is_regular_file(robot_yaml))
    throw input_error(robot_yaml, "a robot file (YAML: urdf, package_dirs, tooling) is needed here");
  CellSpec swapped = *this;
  swapped.robot_urdf.clear();
  swapped.robot_package_dirs.clear();
  swapped.tooling.clear();
  try {
    parse_robot_file(robot_yaml, swapped);
  } catch (const YAML::Exception& e) {
    throw input_error(robot_yaml, "malformed robot file: " + e.msg);
  }
  *this = std::move(swapped);
}

}  // namespace weldtwin
