#include "pipeline/weld_pipeline.hpp"

#include <string>

#include "sim/collision_check.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {

TwinScene::TwinScene(const TwinCell& c, const CellLayout& layout, const Iso3& mount_error,
                     const PartSpec* twin_part)
    : real_robot(mount_error.isApprox(Iso3::Identity())
                     ? c.robot
                     : c.robot.with_mount_offset(SweepOptions().lidar_link, mount_error)),
      world(c.cell, twin_part ? *twin_part : c.part, real_robot, layout) {}

LocalizeSetting localize_setting_for(const TwinCell& cell, LocalizeSetting base) {
  base.table.cell_top_z_m = cell.cell.table.top_z_m;
  return localize_setting_for(cell.part, base);
}

ReplayResult replay_in_twin(const TwinCell& cell, const TwinScene& twin, const WeldPlan& plan,
                            const Iso3& T_base_part_twin, ReplaySetting setting) {
  setting.max_seam_error_m = cell.part.weld_tolerance_m;
  return replay_plan(twin.world, twin.real_robot, plan, cell.part, cell.mesh, T_base_part_twin, setting);
}

WeldPipelineResult weld_pipeline(const std::vector<Vec3>& scan, const std::vector<Vec3>& viewpoints,
                                 const WeldJob& job, const WeldPipelineSetting& setting,
                                 const WeldPipelineHooks& hooks) {
  const TwinCell& c = *job.cell;
  const double tolerance_m = c.part.weld_tolerance_m;
  auto done = [&](PipelineStage stage, const WeldPipelineResult& r) {
    if (hooks.stage_done) hooks.stage_done(stage, r);
  };
  WeldPipelineResult r;

  // 1. Find the part.
  const LocalizeSetting finding = localize_setting_for(c, setting.localize);
  const std::vector<Vec3> no_viewpoints;
  const std::vector<Vec3>& rays = setting.viewpoints ? viewpoints : no_viewpoints;
  r.pose = job.prepared ? localize(scan, *job.prepared, finding, c.seam_points, rays)
                        : localize(scan, c.mesh, finding, c.seam_points, rays);
  if (job.truth_known)
    r.pose_error = pose_error(c.part, r.pose.T_base_part, job.T_base_part_twin, c.symmetry);
  if (!r.pose.found) r.failures.push_back({FailureKind::kPartNotFound, r.pose.reason});
  if (r.pose.found && r.pose_error && r.pose_error->seam_max_m > tolerance_m)
    r.failures.push_back(
        {FailureKind::kLocalization, "seam " + std::to_string(1e3 * r.pose_error->seam_max_m).substr(0, 5) +
                                         " mm off the truth, and the part was accepted"});
  r.seams_within_tolerance = r.pose.found && (!r.pose_error || r.pose_error->seam_max_m <= tolerance_m);
  done(PipelineStage::kFind, r);
  if (!r.pose.found || !setting.plan) return r;

  // 2. Plan, as the controller knows the arm, against the cell as the twin has it (the table, clamps and
  // clutter) with the part where it was found.
  PlanSetting plan_setting = setting.planning;
  if (hooks.before_plan) hooks.before_plan(plan_setting);
  {
    CollisionChecker checker(job.twin->world);
    checker.add_part(c.mesh, r.pose.T_base_part);
    plan_setting.collision = checker;
    r.plan = plan_welds(c.part, r.pose.T_base_part, c.robot, plan_setting);
  }
  plan_setting.collision = nullptr;
  r.plan_setting = plan_setting;
  for (const std::string& p : r.plan->problems) r.failures.push_back({FailureKind::kPlan, p});
  done(PipelineStage::kPlan, r);
  if (!r.plan->ok() || r.plan->samples.empty()) return r;

  // 3. Replay it on the twin's arm, the part where it really stands.
  r.replay = replay_in_twin(c, *job.twin, *r.plan, job.T_base_part_twin, setting.replay);
  for (const std::string& f : r.replay->failures) r.failures.push_back({FailureKind::kReplay, f});
  r.seams_within_tolerance = r.seams_within_tolerance && r.replay->max_seam_error_m <= tolerance_m;
  done(PipelineStage::kReplay, r);
  return r;
}

}  // namespace weldtwin
