// Where to put a part that cannot be welded where it lies: the nearest placement (a move on the table and a
// turn, each costed) at which every seam plans and the plan replays clean in the twin, with the part held by
// the same clamp sites and the clutter where it is. Candidates are taken nearest first, screened by the
// planner's quick station test (as the weldability map), and the first few that pass are planned in full
// and replayed; the first that welds is the suggestion, said as a line an operator can act on.
#pragma once

#include <string>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/mesh_io.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/replay.hpp"

namespace weldtwin {

struct GuidanceSetting {
  double grid_m = 0.02;               ///< candidate moves on this grid round where the part lies
  double yaw_step_rad = deg2rad(15);  ///< candidate turns in these steps
  double max_move_m = 0.6;            ///< no farther than this
  double mm_per_deg = 1.0;            ///< a turn of 1 deg costs as much as a move of this many mm
  size_t max_screened = 4000;         ///< station tests at most
  int max_verified = 8;               ///< full plans and replays at most
  /// A candidate this close (move and turn both) to one that passed the station test but failed in full is
  /// passed over: its transits would meet the same clamp or clutter.
  double retry_apart_m = 0.04;
  double retry_apart_rad = deg2rad(20);
  /// An operator puts a part down within about this much of where asked: a candidate is taken only when the
  /// station test also passes this far off along x, along y and along both (the square's corners), and turned
  /// this far either way.
  double placement_tolerance_m = 0.01;
  double placement_tolerance_rad = deg2rad(5);
  PlanSetting plan;  ///< the planner as the cell uses it (its collision test is set here)
  ReplaySetting replay;
};

struct PlacementSuggestion {
  bool found = false;
  Iso3 T_base_part = Iso3::Identity();  ///< where to put the part
  double move_m = 0.0;                  ///< how far from where it lies
  double turn_rad = 0.0;                ///< and turned by (counter-clockwise seen from above: +)
  std::string instruction;              ///< "turn the part 90 deg clockwise and move it 60 mm towards ..."
  std::string reason;                   ///< when none was found: why
  int screened = 0, verified = 0;       ///< station tests and full plans with replay run
  double seconds = 0.0;
};

/// The nearest placement of the part that welds in the twin, from `now` (the layout where it lies: its
/// clamp sites and the clutter are kept). `symmetry_order`: turns by 360 deg / order leave the part as it
/// was (z_symmetry_order of its mesh), so they are not suggested.
PlacementSuggestion suggest_placement(const CellSpec& cell, const PartSpec& part, const RobotModel& robot,
                                      const Mesh& mesh, const CellLayout& now, int symmetry_order,
                                      const GuidanceSetting& setting = {});

/// The cell as `now` lays it out — its clamp sites and clutter, the part anywhere on the table — so that
/// layout_at(cell, part, T) is the part moved to T with the same clamps, and the clutter where it was.
CellSpec cell_as_laid_out(const CellSpec& cell, const CellLayout& now);

/// The line for the operator: the turn (clockwise or counter-clockwise seen from above, in whole degrees)
/// and the move (towards or away from the robot, to the robot's left or right, in 5 mm steps).
std::string placement_instruction(const Iso3& from, const Iso3& to);

}  // namespace weldtwin
