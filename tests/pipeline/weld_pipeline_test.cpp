// The pipeline's judgement: failures carry their kind, the part's weld tolerance is the bar everywhere, and
// a pose is judged against the truth only where the truth is known. One twin sweep of the default cell.
#include <gtest/gtest.h>

#include "core/cell_spec.hpp"
#include "perception/scan_assembly.hpp"
#include "pipeline/outcome.hpp"
#include "pipeline/weld_pipeline.hpp"
#include "sim/sweep_sim.hpp"
#include "tests/input_error_of.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

struct Swept {
  TwinCell cell{CellSpec::load(test::repo("scenes/cells/default.yaml"))};
  CellLayout layout = make_layout(cell.cell, cell.part, 3);
  TwinScene twin{cell, layout};
  AssembledCloud cloud;
  Swept() {
    LidarSetting lidar;
    lidar.apply(cell.cell.lidar_overrides, cell.cell.source);
    lidar.seed = 3;
    cloud =
        assemble_scan(simulate_sweep(twin.world, twin.real_robot, cell.program, lidar, {}).log, cell.robot);
  }
  WeldJob job(bool truth_known, const Iso3& truth) const {
    WeldJob j;
    j.cell = &cell;
    j.twin = &twin;
    j.T_base_part_twin = truth;
    j.truth_known = truth_known;
    return j;
  }
};

const Swept& swept() {
  static const Swept s;
  return s;
}

WeldPipelineSetting find_only() {
  WeldPipelineSetting s;
  s.plan = false;
  return s;
}

TEST(WeldPipeline, APoseOffTheTruthIsALocalizationFailureOnlyWhereTheTruthIsKnown) {
  const Swept& s = swept();
  // The truth 3 mm from where the part lies: the pose found (where it lies) is 3 mm off it.
  Iso3 wrong = s.layout.T_base_part;
  wrong.translation().x() += 0.003;
  const WeldPipelineResult judged =
      weld_pipeline(s.cloud.points_base, s.cloud.viewpoints_base, s.job(true, wrong), find_only());
  ASSERT_TRUE(judged.pose.found) << judged.pose.reason;
  ASSERT_EQ(judged.failures.size(), 1u);
  EXPECT_EQ(judged.failures[0].kind, FailureKind::kLocalization);
  EXPECT_EQ(judged.failures[0].text().rfind("localization: seam ", 0), 0u) << judged.failures[0].text();
  EXPECT_NEAR(judged.pose_error->seam_max_m, 0.003, 2e-4);
  EXPECT_FALSE(judged.seams_within_tolerance);
  EXPECT_EQ(exit_code(judged.failures), kExitUntrustworthy);

  const WeldPipelineResult unknown =
      weld_pipeline(s.cloud.points_base, s.cloud.viewpoints_base, s.job(false, wrong), find_only());
  EXPECT_FALSE(unknown.pose_error.has_value());
  EXPECT_TRUE(unknown.passed());
  EXPECT_EQ(exit_code(unknown.failures), kExitPassed);
}

TEST(WeldPipeline, ThePartsWeldToleranceIsTheBarOfTheLocalizerAndTheJudgement) {
  const Swept& s = swept();
  const WeldPipelineResult loose = weld_pipeline(s.cloud.points_base, s.cloud.viewpoints_base,
                                                 s.job(true, s.layout.T_base_part), find_only());
  ASSERT_TRUE(loose.passed()) << loose.failures.front().text();
  ASSERT_TRUE(loose.pose_error.has_value());
  // A tolerance below this scan's own seam error bound: the same scan, the same pose, now refused.
  TwinCell tight = s.cell;
  tight.part.weld_tolerance_m = 0.5 * loose.pose.seam_error_bound_m;
  WeldJob job = s.job(true, s.layout.T_base_part);
  job.cell = &tight;
  const WeldPipelineResult refused =
      weld_pipeline(s.cloud.points_base, s.cloud.viewpoints_base, job, find_only());
  ASSERT_FALSE(refused.passed());
  EXPECT_EQ(refused.failures[0].kind, FailureKind::kPartNotFound) << refused.failures[0].text();
  EXPECT_FALSE(refused.seams_within_tolerance);
}

TEST(TwinCell, EachRescanStartsWhereTheProgramBeforeItEndsAndTheyGoWithTheSweepTheyFollow) {
  const CellSpec quick = CellSpec::load(test::repo("scenes/cells/quick_sweep.yaml"));
  const TwinCell cell(quick);
  ASSERT_EQ(cell.rescans.size(), 4u);
  EXPECT_LT((cell.rescans[0].start() - cell.program.moves().back().to).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((cell.rescans[1].start() - cell.rescans[0].moves().back().to).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((cell.rescans[2].start() - cell.rescans[1].moves().back().to).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((cell.rescans[3].start() - cell.rescans[2].moves().back().to).cwiseAbs().maxCoeff(), 1e-9);
  // Swept in turn while the part is not found, and no more than the cell has.
  PoseEstimate refused, found;
  found.found = true;
  EXPECT_TRUE(cell.sweeps_again(refused, 0));
  EXPECT_TRUE(cell.sweeps_again(refused, 3));
  EXPECT_FALSE(cell.sweeps_again(refused, 4));
  EXPECT_FALSE(cell.sweeps_again(found, 0));
  EXPECT_FALSE(TwinCell(CellSpec::load(test::repo("scenes/cells/default.yaml"))).sweeps_again(refused, 0));
  // Refused because the scan's table is not where the cell has it: the LiDAR's mount is off, and a sweep
  // through it again would be off alike.
  PoseEstimate mount_off = refused;
  mount_off.table_known = mount_off.table_off = true;
  EXPECT_FALSE(cell.sweeps_again(mount_off, 0));
  // While a rescan is left, a pose found is taken only where its 99 % region (1.2 times the 95 % bounds
  // the verdict takes) is within the tolerances: 1 mm at the seams, 0.5 deg of turn where the turn matters.
  PoseEstimate near = found;
  near.seam_error_bound_m = 0.00085;  // 1.02 mm at 99 %
  EXPECT_TRUE(cell.sweeps_again(near, 0));
  EXPECT_NE(cell.sweep_again_because(near, 0).find("0.85 mm (95 %) but 1.02 mm at 99 %"), std::string::npos)
      << cell.sweep_again_because(near, 0);
  EXPECT_FALSE(cell.sweeps_again(near, 4));  // none left: the verdict's bar
  near.seam_error_bound_m = 0.0008;          // 0.96 mm at 99 %
  EXPECT_FALSE(cell.sweeps_again(near, 0));
  near.yaw_bound_rad = deg2rad(0.43);  // 0.52 deg at 99 %
  EXPECT_NE(cell.sweep_again_because(near, 1).find("turn within 0.43 deg (95 %) but 0.52 deg at 99 %"),
            std::string::npos)
      << cell.sweep_again_because(near, 1);
  near.yaw_bound_rad = deg2rad(0.40);
  EXPECT_FALSE(cell.sweeps_again(near, 0));
  // A full circle's turn moves no weld: only its seam bound counts.
  CellSpec round = quick;
  round.part_spec = test::repo("scenes/parts/round_on_plate.yaml");
  const TwinCell round_cell(round);
  EXPECT_FALSE(round_cell.turn_matters);
  near.yaw_bound_rad = deg2rad(5.0);
  EXPECT_FALSE(round_cell.sweeps_again(near, 0));
  // Another sweep replaces the cell's rescans with it, unless rescans are given as well.
  EXPECT_TRUE(TwinCell(quick, test::repo("scenes/sweeps/crossed_passes.yaml")).rescans.empty());
  const std::string crossing = test::repo("scenes/sweeps/crossing_pass.yaml");
  const std::string outer = test::repo("scenes/sweeps/outer_passes.yaml");
  EXPECT_EQ(TwinCell(quick, test::repo("scenes/sweeps/one_pass.yaml"), {crossing}).rescans.size(), 1u);
  // The default sweep ends elsewhere (J1 at -100 deg; the crossing pass starts at +125).
  const std::string e = test::input_error_of(
      [&] { TwinCell(CellSpec::load(test::repo("scenes/cells/default.yaml")), "", {crossing}); });
  EXPECT_NE(e.find("crossing_pass.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("joint 1 at 125.00 deg, that program ends at -100.00 deg"), std::string::npos) << e;
  // The outer passes start where the crossing pass ends, not where the one pass does (J1 at -125 against
  // +125 deg).
  const std::string o =
      test::input_error_of([&] { TwinCell(quick, test::repo("scenes/sweeps/one_pass.yaml"), {outer}); });
  EXPECT_NE(o.find("outer_passes.yaml"), std::string::npos) << o;
  EXPECT_NE(o.find("joint 1 at -125.00 deg, that program ends at 125.00 deg"), std::string::npos) << o;
  const std::string w = test::input_error_of([&] {
    TwinCell(quick, test::repo("scenes/sweeps/one_pass.yaml"), {outer, crossing});
  });
  EXPECT_NE(w.find("outer_passes.yaml"), std::string::npos) << w;
}

TEST(Outcome, ExitCodesFollowTheFirstFailuresKind) {
  EXPECT_EQ(exit_code({}), 0);
  EXPECT_EQ(exit_code({{FailureKind::kPlan, "seam 'a': out of reach"}}), 3);
  EXPECT_EQ(exit_code({{FailureKind::kRobot, "stopped"}}, true), 130);
  EXPECT_EQ(exit_code({{FailureKind::kReplay, "contact"}, {FailureKind::kRobot, "x"}}, true), 3);
  EXPECT_EQ((Failure{FailureKind::kPartNotFound, "no table"}).text(), "part not found: no table");
  EXPECT_EQ(tolerance_text(1e-3), "limit 1 mm");
  EXPECT_EQ(tolerance_text(5e-4), "limit 0.5 mm");
}

}  // namespace
}  // namespace weldtwin
