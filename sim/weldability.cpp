#include "sim/weldability.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>

#include "core/parallel_for.hpp"
#include "sim/collision_check.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {

const char* placement_kind_name(PlacementKind kind) {
  switch (kind) {
    case PlacementKind::kWelds:
      return "welds";
    case PlacementKind::kNoRoom:
      return "no_room";
    case PlacementKind::kOutOfReach:
      return "out_of_reach";
    case PlacementKind::kCollides:
      return "collides";
  }
  return "?";
}

size_t WeldabilityMap::count(PlacementKind kind) const {
  size_t n = 0;
  for (const MapPlacement& p : placements) n += p.kind == kind;
  return n;
}

WeldabilityMap weldability_map(const CellSpec& cell_file, const PartSpec& part, const RobotModel& robot,
                               const Mesh& mesh, const ReachSetting& setting,
                               const std::function<void(size_t, size_t)>& progress) {
  const auto started = std::chrono::steady_clock::now();
  CellSpec cell = cell_file;
  cell.placement.area = PlacementSpec::Area::kTable;  // the whole table, not the cell's ring
  if (!(setting.grid_m > 0) || !(setting.yaw_step_rad > 0))
    throw std::invalid_argument("weldability map: grid and yaw step must be positive");
  WeldabilityMap map;
  map.part = part.name;
  map.cell = cell.name;
  map.grid_m = setting.grid_m;
  map.yaw_step_rad = setting.yaw_step_rad;
  const TableSpec& t = cell.table;
  map.x0_m = t.x_min_m;
  map.y0_m = t.y_min_m;
  map.nx = static_cast<size_t>(std::floor((t.x_max_m - t.x_min_m) / setting.grid_m + 1e-9)) + 1;
  map.ny = static_cast<size_t>(std::floor((t.y_max_m - t.y_min_m) / setting.grid_m + 1e-9)) + 1;
  map.nyaw = static_cast<size_t>(std::ceil(2 * kPi / setting.yaw_step_rad - 1e-9));
  map.placements.resize(map.nx * map.ny * map.nyaw);

  // Which placements have room for the part and its clamps; the world is built at the first of them.
  std::vector<CellLayout> layouts(map.placements.size());
  std::vector<size_t> roomy;
  for (size_t ix = 0; ix < map.nx; ++ix)
    for (size_t iy = 0; iy < map.ny; ++iy)
      for (size_t iyaw = 0; iyaw < map.nyaw; ++iyaw) {
        const size_t i = (ix * map.ny + iy) * map.nyaw + iyaw;
        MapPlacement& p = map.placements[i];
        p.x_m = map.x0_m + static_cast<double>(ix) * setting.grid_m;
        p.y_m = map.y0_m + static_cast<double>(iy) * setting.grid_m;
        p.yaw_rad = static_cast<double>(iyaw) * setting.yaw_step_rad;
        layouts[i] = layout_at(cell, part, planar_pose(p.x_m, p.y_m, t.top_z_m, p.yaw_rad));
        p.reason = layout_problem(cell, part, layouts[i]);
        if (p.reason.empty()) roomy.push_back(i);
      }
  if (roomy.empty()) {
    map.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return map;
  }
  const MujocoWorld world(cell, part, robot, layouts[roomy.front()]);

  PlanSetting plan_setting = setting.plan;
  plan_setting.stations_only = true;
  // Each worker its own collision checker (a model copy and data), moved from placement to placement.
  struct Worker {
    CollisionChecker checker;
    PlanSetting plan;
  };
  std::atomic<size_t> done{0};
  std::mutex progress_mutex;
  parallel_for_with(
      roomy.size(), setting.threads,
      [&] {
        Worker w{CollisionChecker(world), plan_setting};
        w.checker.add_part(mesh, layouts[roomy.front()].T_base_part);
        w.plan.collision = w.checker;
        return w;
      },
      [&](Worker& w, size_t k) {
        const size_t i = roomy[k];
        MapPlacement& p = map.placements[i];
        w.checker.place(layouts[i]);
        const WeldPlan plan = plan_welds(part, layouts[i].T_base_part, robot, w.plan);
        p.kind = plan.ok()                                ? PlacementKind::kWelds
                 : plan.failure == PlanFailure::kCollides ? PlacementKind::kCollides
                                                          : PlacementKind::kOutOfReach;
        p.reason = plan.ok() ? "" : plan.problems.front();
        const size_t d = ++done;
        if (progress && (d % 256 == 0 || d == roomy.size())) {
          const std::lock_guard<std::mutex> lock(progress_mutex);
          progress(d, roomy.size());
        }
      });
  map.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return map;
}

}  // namespace weldtwin
