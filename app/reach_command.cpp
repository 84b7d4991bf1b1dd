#include "app/reach_command.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include <nlohmann/json.hpp>

#include "app/json_file.hpp"
#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "core/mesh_file.hpp"
#include "core/scenes.hpp"
#include "sim/weldability_picture.hpp"

namespace weldtwin {

CellSpec cell_for_part(const std::string& cell_file, const std::string& part_file,
                       const std::string& robot_file) {
  CellSpec cell = CellSpec::load(cell_file);
  if (!robot_file.empty()) cell.use_robot_file(robot_file);
  if (part_file.empty()) return cell;
  cell.part_spec = std::filesystem::absolute(part_file).lexically_normal().string();
  const PartSpec part = PartSpec::load(cell.part_spec);
  const int sites = static_cast<int>(part.clamp_sites.size());
  bool fits = true;
  for (int s : cell.clamp_sites) fits &= s >= 0 && s < sites;
  if (!fits) {
    cell.clamp_sites.clear();
    if (sites > 0) cell.clamp_sites.push_back(0);
    if (sites > 1) cell.clamp_sites.push_back(sites / 2);
  }
  return cell;
}

nlohmann::json map_to_json(const WeldabilityMap& map) {
  nlohmann::json j;
  j["part"] = map.part;
  j["cell"] = map.cell;
  j["grid_m"] = map.grid_m;
  j["yaw_step_deg"] = rad2deg(map.yaw_step_rad);
  j["positions"] = {{"nx", map.nx}, {"ny", map.ny}, {"x0_m", map.x0_m}, {"y0_m", map.y0_m}};
  j["yaws"] = map.nyaw;
  j["seconds"] = std::round(map.seconds * 1e3) / 1e3;
  nlohmann::json counts;
  for (PlacementKind k :
       {PlacementKind::kWelds, PlacementKind::kOutOfReach, PlacementKind::kCollides, PlacementKind::kNoRoom})
    counts[placement_kind_name(k)] = map.count(k);
  j["counts"] = counts;
  std::map<std::string, size_t> reason_index;
  nlohmann::json reasons = nlohmann::json::array(), placements = nlohmann::json::array();
  for (const MapPlacement& p : map.placements) {
    if (p.kind == PlacementKind::kNoRoom) continue;
    size_t r = 0;
    if (!p.reason.empty()) {
      auto [it, added] = reason_index.emplace(p.reason, reasons.size());
      if (added) reasons.push_back(p.reason);
      r = it->second + 1;
    }
    placements.push_back({std::round(p.x_m * 1e4) / 1e4, std::round(p.y_m * 1e4) / 1e4,
                          std::round(rad2deg(p.yaw_rad) * 100) / 100, placement_kind_name(p.kind), r});
  }
  j["placement_columns"] = {"x_m", "y_m", "yaw_deg", "kind", "reason (1-based index into reasons; 0: none)"};
  j["placements"] = std::move(placements);
  j["reasons"] = std::move(reasons);
  return j;
}

int run_reach(const ReachCommand& cmd) {
  if (!(cmd.grid_mm >= 5.0 && cmd.grid_mm <= 200.0))
    throw InputError("--grid-mm must be 5-200 mm (got " + std::to_string(cmd.grid_mm) + ")");
  if (!(cmd.yaw_step_deg >= 1.0 && cmd.yaw_step_deg <= 180.0))
    throw InputError("--yaw-step-deg must be 1-180 deg (got " + std::to_string(cmd.yaw_step_deg) + ")");
  const std::string cell_file = cmd.cell.empty() ? scene_file("cells/default.yaml") : cmd.cell;
  const CellSpec cell = cell_for_part(cell_file, cmd.part, cmd.robot);
  const PartSpec part = PartSpec::load(cell.part_spec);
  const RobotModel robot = load_cell_robot(cell);
  const Mesh mesh = load_mesh(part.mesh_path);
  ReachSetting setting;
  setting.grid_m = 1e-3 * cmd.grid_mm;
  setting.yaw_step_rad = deg2rad(cmd.yaw_step_deg);
  std::filesystem::create_directories(cmd.out);
  if (!cmd.quiet)
    std::fprintf(stderr, "reach: part '%s' in cell '%s', %.0f mm grid, yaw every %.0f deg\n",
                 part.name.c_str(), cell.name.c_str(), cmd.grid_mm, cmd.yaw_step_deg);
  const WeldabilityMap map =
      weldability_map(cell, part, robot, mesh, setting, [&](size_t done, size_t total) {
        if (!cmd.quiet) std::fprintf(stderr, "\rreach: %zu / %zu placements with room judged", done, total);
      });
  if (!cmd.quiet) std::fprintf(stderr, "\n");
  write_json_file(cmd.out + "/map.json", map_to_json(map), -1);
  weldability_picture(map).write_png(cmd.out + "/map.png");
  const size_t roomy = map.placements.size() - map.count(PlacementKind::kNoRoom);
  std::printf(
      "%zu of %zu placements with room weld (%.0f %%; out of reach %zu, collides %zu), %.1f s; %s/map.png, "
      "%s/map.json\n",
      map.count(PlacementKind::kWelds), roomy,
      roomy ? 100.0 * static_cast<double>(map.count(PlacementKind::kWelds)) / static_cast<double>(roomy)
            : 0.0,
      map.count(PlacementKind::kOutOfReach), map.count(PlacementKind::kCollides), map.seconds,
      cmd.out.c_str(), cmd.out.c_str());
  return 0;
}

}  // namespace weldtwin
