// Where on the table a part can be welded. The weldability map judges a grid of placements (position and
// yaw, the part held by the cell's clamps) by the planner's quick test: every seam has a way whose stations,
// approach and departure poses the arm reaches clear of the table, the clamps, the clutter and the part.
// That is necessary for a plan, not sufficient (the moves between seams are not tried): a placement to
// suggest is the nearest one the map allows that also plans in full and replays clean in the twin.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/mesh_io.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"

namespace weldtwin {

struct ReachSetting {
  double grid_m = 0.02;               ///< spacing of the positions over the table top
  double yaw_step_rad = deg2rad(15);  ///< spacing of the yaws, from 0
  int threads = 0;                    ///< 0: one per core
  PlanSetting plan;                   ///< the planner's search (stations_only is set by the map)
};

/// What the map says of one placement.
enum class PlacementKind {
  kWelds,       ///< every seam's stations reached clear of the cell
  kNoRoom,      ///< the part or its clamps do not fit there (off the table, on the robot base, on clutter)
  kOutOfReach,  ///< a seam the arm does not reach within its limits
  kCollides,    ///< a seam the arm reaches only where it collides
};
const char* placement_kind_name(PlacementKind kind);

struct MapPlacement {
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;  ///< the part's origin on the table, base frame
  PlacementKind kind = PlacementKind::kNoRoom;
  std::string reason;  ///< the first seam's problem, or where it does not fit ("" when it welds)
};

struct WeldabilityMap {
  std::string part, cell;
  double grid_m = 0.0, yaw_step_rad = 0.0;
  size_t nx = 0, ny = 0, nyaw = 0;
  double x0_m = 0.0, y0_m = 0.0;         ///< the first grid position
  std::vector<MapPlacement> placements;  ///< index (ix * ny + iy) * nyaw + iyaw
  double seconds = 0.0;

  const MapPlacement& at(size_t ix, size_t iy, size_t iyaw) const {
    return placements[(ix * ny + iy) * nyaw + iyaw];
  }
  size_t count(PlacementKind kind) const;
};

/// The map of where `part` (held by the cell's clamp sites) can be welded in `cell`. `progress(done, total)`
/// is called now and then from the calling thread's workers (serialised).
WeldabilityMap weldability_map(const CellSpec& cell, const PartSpec& part, const RobotModel& robot,
                               const Mesh& mesh, const ReachSetting& setting = {},
                               const std::function<void(size_t, size_t)>& progress = {});

}  // namespace weldtwin
