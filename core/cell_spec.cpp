#include "core/cell_spec.hpp"

#include <filesystem>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/yaml_util.hpp"

namespace weldtwin {
namespace {

std::string existing(const std::string& file, const YAML::Node& root, const std::string& key) {
  const std::string path = yaml::resolve(file, yaml::text(root, key, file));
  if (!is_file(path)) throw input_error(file, "field '" + key + "': file '" + path + "' does not exist");
  return path;
}

CellSpec parse(const std::string& file) {
  const YAML::Node root = yaml::load_file(file);
  CellSpec cell;
  cell.source = file;
  cell.name = root["name"] ? yaml::text(root, "name", file) : std::filesystem::path(file).stem().string();
  cell.environment_mjcf = existing(file, root, "environment");
  cell.robot_urdf = existing(file, root, "robot");
  cell.sweep_program = existing(file, root, "sweep");

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

CellSpec CellSpec::load(const std::string& yaml_path) {
  try {
    return parse(yaml_path);
  } catch (const YAML::Exception& e) {
    throw input_error(yaml_path, "malformed cell: " + e.msg);
  }
}

}  // namespace weldtwin
