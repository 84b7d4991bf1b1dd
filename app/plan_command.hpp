// `weldtwin plan`: the weld program for a part at a pose (plan JSON and CSV, docs/design.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "app/plan_files.hpp"
#include "core/geometry.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "core/scenes.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {

struct PlanCommand {
  std::string part;  ///< part spec YAML
  std::string pose;  ///< pose JSON with T_base_part
  std::string cell;  ///< "" = the default cell (its robot)
  std::string out;   ///< plan JSON
  std::string csv;   ///< "" = none
  bool quiet = false;
};

/// The cell file given, or the default cell of the repository when none was.
inline std::string cell_or_default(const std::string& cell) {
  return cell.empty() ? scene_file("cells/default.yaml") : cell;
}

/// The plan JSON of docs/design.md.
nlohmann::json plan_to_json(const WeldPlan& plan, const PartSpec& part, const RobotModel& robot,
                            const PlanSetting& setting);

/// Returns the exit code: 0 planned, 3 a seam cannot be welded (the plan file says why). Throws InputError.
int run_plan(const PlanCommand& cmd);

}  // namespace weldtwin
