// The pose and plan files other tools hand to `weldtwin plan`, `replay` and `run` (docs/design.md): read
// and checked, every problem an InputError naming the file.
#pragma once

#include <string>

#include "core/geometry.hpp"
#include "core/part_spec.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {

/// T_base_part from a pose JSON; throws InputError naming the file.
Iso3 read_pose(const std::string& path);

/// The samples of a plan JSON (t, q, tcp, seam, arc); throws InputError naming the file.
WeldPlan read_plan(const std::string& path);

/// Whether the plan read from `path` welds `part`: every sample's seam is one of the part's, and every seam
/// of the part has arc-on samples. Throws InputError naming the file and the seam.
void check_plan_for_part(const WeldPlan& plan, const PartSpec& part, const std::string& path);

}  // namespace weldtwin
