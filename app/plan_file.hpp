// The plan file (docs/design.md): the timed joint trajectory with its TCP poses, seams and arc state that
// `weldtwin plan` and `run` write, and `replay`, `run --plan` and the robot gate read and check (every
// problem an InputError naming the file).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/geometry.hpp"
#include "core/part_spec.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {

/// The samples of a plan JSON (t, q, tcp, seam, arc); throws InputError naming the file.
WeldPlan read_plan(const std::string& path);

/// Whether the plan read from `path` welds `part`: every sample's seam is one of the part's, and every seam
/// of the part has arc-on samples. Throws InputError naming the file and the seam.
void check_plan_for_part(const WeldPlan& plan, const PartSpec& part, const std::string& path);

/// The plan JSON: the plan's figures, its seams with the angles chosen, and every sample.
nlohmann::json plan_to_json(const WeldPlan& plan, const PartSpec& part, const RobotModel& robot,
                            const PlanSetting& setting);

/// The plan's joint trajectory as CSV: a header `t,j1,...,j6`, then one line per sample [s], [rad].
std::string plan_to_csv(const WeldPlan& plan);

}  // namespace weldtwin
