// The run report: DIR/report.json (every figure) and DIR/report.html (self-contained: pictures and plots
// embedded, no network), led by the true-seam error because it decides whether the weld lands.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "perception/localizer.hpp"
#include "perception/pose_error.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/placement_guidance.hpp"
#include "sim/replay.hpp"
#include "sim/weldability.hpp"

namespace weldtwin {

struct RunRecord {
  const CellSpec* cell = nullptr;
  const PartSpec* part = nullptr;
  const CellLayout* layout = nullptr;
  const MujocoWorld* world = nullptr;
  std::vector<Vec3> cloud;  ///< base frame, of every sweep
  std::vector<std::string>
      sweeps;  ///< the sweep programs swept, in order (after the first: the cell's rescans)
  std::vector<std::string> rescan_reasons;  ///< why each rescan was swept (TwinCell::sweep_again_because)
  std::vector<Label> cloud_labels;          ///< truth, per point
  const PoseEstimate* pose = nullptr;
  std::optional<PoseError> pose_error;  ///< against the truth, when known (the twin made the scan)
  const WeldPlan* plan = nullptr;
  std::string plan_sha256;  ///< of DIR/plan.json as written: the plan the robot gate lets through
  const ReplayResult* replay = nullptr;  ///< null when there was nothing to replay
  /// When the part cannot be welded where it was found: where to put it (null: not asked), and the map of
  /// where it welds on the table (null: not drawn), with the part where it was found and the suggestion.
  const PlacementSuggestion* suggestion = nullptr;
  const WeldabilityMap* weldability = nullptr;
  std::vector<std::pair<std::string, double>> stage_seconds;
  bool passed = false;
  std::vector<std::string> reasons;  ///< why it failed (empty when passed)
};

/// The report's figures (what report.json holds).
nlohmann::json report_json(const RunRecord& run);

/// Writes DIR/report.json and DIR/report.html; with `renders`, OSMesa pictures and gnuplot plots too
/// (PNG files in DIR as well). Returns the seconds spent rendering and plotting.
double write_report(const RunRecord& run, const std::string& dir, bool renders);

}  // namespace weldtwin
