#include "app/plan_command.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>

#include "app/json_file.hpp"
#include "app/plan_file.hpp"
#include "app/pose_file.hpp"
#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "core/scenes.hpp"
#include "perception/mesh_io.hpp"
#include "pipeline/outcome.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/collision_check.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {

int run_plan(const PlanCommand& cmd) {
  const CellSpec cell = CellSpec::load(cell_or_default(cmd.cell));
  const RobotModel robot = load_cell_robot(cell);
  const PartSpec part = PartSpec::load(cmd.part);
  const Iso3 T_base_part = read_pose(cmd.pose);
  // A part rests on the table: a pose that puts it into the table top, or far above it, is no pose of it.
  {
    constexpr double kRestTolerance = 0.02;  // a mount off by some millimetres still plans [m]
    double lowest = 1e300;
    for (const Vec3& v : load_mesh(part.mesh_path).vertices) lowest = std::min(lowest, (T_base_part * v).z());
    const double off = lowest - cell.table.top_z_m;
    if (std::abs(off) > kRestTolerance) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "the pose puts the part's lowest point %.0f mm %s the table top of %s",
                    1e3 * std::abs(off), off < 0 ? "below" : "above", cell_or_default(cmd.cell).c_str());
      throw input_error(cmd.pose, buf);
    }
  }
  // With a cell, the plan avoids what the cell holds (its table, clamps and clutter as the cell file places
  // them, the part where the pose puts it), as `weldtwin run` plans; without one, joint limits only.
  PlanSetting setting;
  const bool checked = !cmd.cell.empty();
  std::optional<MujocoWorld> world;
  std::optional<CollisionChecker> checker;
  if (checked) {
    world.emplace(cell, part, robot, make_layout(cell, part, std::nullopt));
    checker.emplace(*world);
    checker->add_part(load_mesh(part.mesh_path), T_base_part);
    setting.collision = *checker;
  }
  const WeldPlan plan = plan_welds(part, T_base_part, robot, setting);

  nlohmann::json out = plan_to_json(plan, part, robot, setting);
  out["collisions_checked"] = checked;
  write_json_file(cmd.out, out, -1);
  if (!cmd.csv.empty()) write_text_file(cmd.csv, plan_to_csv(plan));
  if (!cmd.quiet) {
    std::fprintf(stderr, "plan: %s, %zu seams, %.1f s, %zu samples at %.0f Hz -> %s\n", part.name.c_str(),
                 plan.seams.size(), plan.duration_s(), plan.samples.size(), setting.sample_hz,
                 cmd.out.c_str());
    for (const auto& n : plan.notes) std::fprintf(stderr, "plan: note: %s\n", n.c_str());
    if (!checked)
      std::fprintf(
          stderr,
          "plan: note: collisions not checked (joint limits only; give --cell to plan against its "
          "table, clamps and clutter): replay it in the cell (weldtwin replay %s) before it goes to a "
          "robot\n",
          cmd.out.c_str());
  }
  if (!plan.ok()) {
    std::fprintf(stderr, "weldtwin: %s: %s\n", cmd.part.c_str(), plan.problems.front().c_str());
    return kExitUntrustworthy;
  }
  return kExitPassed;
}

}  // namespace weldtwin
