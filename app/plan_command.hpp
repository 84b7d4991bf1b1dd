// `weldtwin plan`: the weld program for a part at a pose (plan JSON and CSV, docs/design.md).
#pragma once

#include <string>

namespace weldtwin {

struct PlanCommand {
  std::string part;  ///< part spec YAML
  std::string pose;  ///< pose JSON with T_base_part
  std::string cell;  ///< "" = the default cell (its robot)
  std::string out;   ///< plan JSON
  std::string csv;   ///< "" = none
  bool quiet = false;
};

/// Returns the exit code: 0 planned, 3 a seam cannot be welded (the plan file says why). Throws InputError.
int run_plan(const PlanCommand& cmd);

}  // namespace weldtwin
