// `weldtwin reach PART.yaml [CELL.yaml] --out DIR`: where on the cell's table the part can be welded — the
// weldability map (sim/weldability.hpp) as DIR/map.json and DIR/map.png.
#pragma once

#include <string>

#include <nlohmann/json_fwd.hpp>

#include "sim/weldability.hpp"

namespace weldtwin {

struct ReachCommand {
  std::string part;   ///< part spec YAML
  std::string cell;   ///< "" = scenes/cells/default.yaml
  std::string robot;  ///< "" = the cell's own robot file
  std::string out = "out/reach";
  double grid_mm = 20.0;
  double yaw_step_deg = 15.0;
  bool quiet = false;
};

/// 0, or throws InputError for bad input.
int run_reach(const ReachCommand& cmd);

/// The cell for a part: the cell file with `part` in it, its clamp sites kept when the part has them (else
/// the part's first and middle sites), and another robot file when one is given.
CellSpec cell_for_part(const std::string& cell_file, const std::string& part_file,
                       const std::string& robot_file);

/// The map as JSON: counts per kind, the grid, and each placement with room as [x_m, y_m, yaw_deg, kind,
/// reason index] with the reasons listed once.
nlohmann::json map_to_json(const WeldabilityMap& map);

}  // namespace weldtwin
