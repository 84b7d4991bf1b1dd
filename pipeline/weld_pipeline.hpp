// The weld job's pipeline after the sweep: find the part in the scan -> plan its seams against the cell ->
// replay the plan in the twin -> judge. `weldtwin run`, `weldtwin bench` and the examples call it; what
// differs between them (where the scan came from, whether the truth is known, what is written, progress)
// is passed in. The sweep before it is the twin's (sweep_twin) or a real one (hw/scan_source.hpp).
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "core/geometry.hpp"
#include "perception/localizer.hpp"
#include "perception/pose_error.hpp"
#include "pipeline/outcome.hpp"
#include "pipeline/twin_cell.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/replay.hpp"

namespace weldtwin {

/// The twin of one job: the robot with its LiDAR where it really sits (the URDF's mount moved by
/// `mount_error`) and the MuJoCo world of the cell laid out so.
struct TwinScene {
  RobotModel real_robot;
  MujocoWorld world;
  /// `twin_part`: the part the world holds, when it differs from its CAD (null: the cell's part).
  TwinScene(const TwinCell& cell, const CellLayout& layout, const Iso3& mount_error = Iso3::Identity(),
            const PartSpec* twin_part = nullptr);
};

struct WeldPipelineSetting {
  LocalizeSetting localize;  ///< its weld tolerance is the part's (PartSpec::weld_tolerance_m)
  bool viewpoints = true;    ///< localize with every point's viewpoint (off: as other tools' clouds)
  bool plan = true;          ///< plan and replay once the part is found (off: find it only)
  PlanSetting planning;      ///< its collision test is set here: the world, and the part where it was found
  ReplaySetting replay;      ///< its seam limit is the part's weld tolerance
};

/// What the pipeline works on besides the scan.
struct WeldJob {
  const TwinCell* cell = nullptr;          ///< the part and the robot as the controller knows it
  const PreparedPart* prepared = nullptr;  ///< the part made ready for the localizer (null: from the mesh)
  const TwinScene* twin = nullptr;         ///< the cell as it is: the collision model and the replay's stage
  Iso3 T_base_part_twin = Iso3::Identity();  ///< where the twin's part stands (the replay measures to it)
  bool truth_known = false;  ///< the twin made the scan: T_base_part_twin is where the scanned part lay
};

enum class PipelineStage { kFind, kPlan, kReplay };

struct WeldPipelineResult {
  PoseEstimate pose;
  std::optional<PoseError> pose_error;  ///< against the truth, when known
  std::optional<WeldPlan> plan;         ///< when planned (found, and asked to)
  PlanSetting plan_setting;             ///< as planned with (no collision test: what the plan file records)
  std::optional<ReplayResult> replay;   ///< when replayed (planned, and the plan good)
  std::vector<Failure> failures;        ///< in the order found; empty: passed
  /// Found, and (when the truth is known) every seam point within the weld tolerance of the truth, and every
  /// replayed arc-on torch position too.
  bool seams_within_tolerance = false;
  bool passed() const { return failures.empty(); }
};

struct WeldPipelineHooks {
  /// Before planning: e.g. start from where a real arm stands.
  std::function<void(PlanSetting&)> before_plan;
  /// After each stage that ran, with the result so far (progress lines, timings).
  std::function<void(PipelineStage, const WeldPipelineResult&)> stage_done;
};

/// The localizer's setting for the cell's part (localize_setting_for) with where the cell has its table: a
/// scan that shows it elsewhere is refused (the LiDAR's mount is off).
LocalizeSetting localize_setting_for(const TwinCell& cell, LocalizeSetting base = {});

/// The replay stage alone: `plan` on the twin's arm, the part at `T_base_part_twin`, the seams judged with
/// the part's weld tolerance (`setting`'s seam limit is replaced by it).
ReplayResult replay_in_twin(const TwinCell& cell, const TwinScene& twin, const WeldPlan& plan,
                            const Iso3& T_base_part_twin, ReplaySetting setting = {});

/// Runs the pipeline on a base-frame scan (`viewpoints`: per point, or empty). Throws only what its stages
/// throw for bad input.
WeldPipelineResult weld_pipeline(const std::vector<Vec3>& scan, const std::vector<Vec3>& viewpoints,
                                 const WeldJob& job, const WeldPipelineSetting& setting,
                                 const WeldPipelineHooks& hooks = {});

}  // namespace weldtwin
