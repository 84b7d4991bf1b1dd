// Where a part can be welded: placements anywhere on the table, one collision checker moved between
// placements, the weldability map, and the placement suggested when a part does not weld where it lies.
#include <gtest/gtest.h>

#include <array>

#include <cmath>
#include <random>

#include "core/mesh_file.hpp"
#include "perception/pose_error.hpp"
#include "planning/ik_aubo.hpp"
#include "sim/collision_check.hpp"
#include "sim/placement_guidance.hpp"
#include "sim/weldability.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using test::Cell;

double yaw_of(const Iso3& T) {
  return std::atan2(T.linear()(1, 0), T.linear()(0, 0));
}

// The planner in a world, against its table, clamps, clutter and the part at T_base_part.
WeldPlan plan_in(const MujocoWorld& world, const PartSpec& part, const Mesh& mesh, const RobotModel& robot,
                 const Iso3& T_base_part, bool stations_only = false) {
  CollisionChecker checker(world);
  checker.add_part(mesh, T_base_part);
  PlanSetting setting;
  setting.collision = checker;
  setting.stations_only = stations_only;
  return plan_welds(part, T_base_part, robot, setting);
}

TEST(Placement, TableAreaDrawsBeyondTheRingAndEveryLayoutFits) {
  CellSpec spec = CellSpec::load(test::repo("scenes/cells/default.yaml"));
  const PartSpec part = PartSpec::load(spec.part_spec);
  spec.placement.area = PlacementSpec::Area::kTable;
  CellSpec ring = spec;
  ring.placement.area = PlacementSpec::Area::kRing;
  int outside_ring = 0;
  for (uint64_t seed = 1; seed <= 60; ++seed) {
    const CellLayout layout = make_layout(spec, part, seed);
    EXPECT_EQ(layout_problem(spec, part, layout), "") << seed;
    const std::string in_ring = layout_problem(ring, part, layout);
    outside_ring += in_ring.find("out of reach") != std::string::npos;
  }
  EXPECT_GE(outside_ring, 10);  // a table 0.8 x 1.2 m is mostly not the ring
}

TEST(Placement, DrawnLayoutsLeaveTheArmAtHomeClear) {
  // A clutter box or a clamp handle beside the base where the shoulder's housing hangs made every plan of its
  // layout fail at the first move: draws keep the part, its clamps and clutter off that circle.
  CellSpec spec = CellSpec::load(test::repo("scenes/cells/default.yaml"));
  spec.placement.area = PlacementSpec::Area::kTable;
  const PartSpec part = PartSpec::load(spec.part_spec);
  const Mesh mesh = load_mesh(part.mesh_path);
  const RobotModel robot = load_cell_robot(spec);
  const JointVector home = PlanSetting().home;
  int near = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    const CellLayout layout = make_layout(spec, part, seed);
    near += layout.T_base_part.translation().head<2>().norm() < 0.40;
    const MujocoWorld world(spec, part, robot, layout);
    CollisionChecker checker(world);
    checker.add_part(mesh, layout.T_base_part);
    EXPECT_EQ(checker(home), "") << "seed " << seed;
  }
  EXPECT_GE(near, 3) << "some parts must stand near the robot for the test to mean anything";
  // A box where the shoulder hangs is refused.
  CellLayout by_the_base = make_layout(spec, part, 1);
  ClutterItem box;
  box.size_m = Vec3(0.08, 0.08, 0.07);
  box.x_m = 0.03, box.y_m = -0.23;
  by_the_base.clutter = {box};
  EXPECT_NE(layout_problem(spec, part, by_the_base).find("overlaps the robot base"), std::string::npos);
}

TEST(Placement, AMovedCheckerAnswersAsOneBuiltThere) {
  const Cell a("scenes/cells/default.yaml");  // the cell's own layout: its clamp sites and clutter
  // The part and its clamps moved to another seed's pose; the clutter stays.
  const CellLayout there = layout_at(a.spec, a.part, make_layout(a.spec, a.part, 5).T_base_part);
  const Mesh mesh = load_mesh(a.part.mesh_path);
  CollisionChecker moved(*a.world);
  moved.add_part(mesh, a.layout.T_base_part);
  moved.place(there);
  const MujocoWorld world_there(a.spec, a.part, a.robot, there);
  CollisionChecker built(world_there);
  built.add_part(mesh, there.T_base_part);
  CollisionChecker stayed(*a.world);
  stayed.add_part(mesh, a.layout.T_base_part);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const AuboIk ik(a.robot, "tcp");
  std::vector<JointVector> qs;
  // The torch round the part where it now stands (tilted up to 60 deg), and the arm anywhere.
  while (qs.size() < 300) {
    const Vec3 at = there.T_base_part * Vec3(0.12 * u(rng), 0.12 * u(rng), 0.06 + 0.06 * u(rng));
    const Mat3 R = (Eigen::AngleAxisd(kPi * u(rng), Vec3::UnitZ()) *
                    Eigen::AngleAxisd(kPi - deg2rad(60) * std::abs(u(rng)), Vec3::UnitX()))
                       .toRotationMatrix();
    for (const IkSolution& s : ik.solve(make_transform(at, R)))
      if (s.valid && s.within_limits) qs.push_back(s.q);
  }
  for (int k = 0; k < 300; ++k) qs.push_back(test::random_q(a.robot, rng));
  int hits = 0, differ_from_before = 0;
  for (size_t k = 0; k < qs.size(); ++k) {
    const JointVector& q = qs[k];
    const std::string m = moved(q), w = built(q);
    EXPECT_EQ(m.empty(), w.empty()) << k << ": moved '" << m << "' built '" << w << "'";
    hits += !w.empty();
    differ_from_before += m.empty() != stayed(q).empty();
  }
  EXPECT_GT(hits, 50);
  EXPECT_GT(differ_from_before, 0) << "the placements must differ for the test to mean anything";
}

TEST(Placement, InstructionSaysTheTurnAndTheMoveFromTheRobotsSide) {
  const Iso3 from = planar_pose(0.40, 0.0, 0.0, 0.0);
  EXPECT_EQ(placement_instruction(from, planar_pose(0.35, 0.02, 0.0, deg2rad(-90))),
            "turn the part 90 deg clockwise (seen from above) and move it 50 mm towards the robot and 20 mm "
            "to the robot's left");
  EXPECT_EQ(placement_instruction(from, planar_pose(0.46, 0.0, 0.0, 0.0)),
            "move the part 60 mm away from the robot");
  // At the robot's left side (bearing +90 deg), towards the robot is -y and the robot's left is -x.
  const Iso3 side = planar_pose(0.0, 0.5, 0.0, deg2rad(10));
  EXPECT_EQ(
      placement_instruction(side, planar_pose(-0.03, 0.45, 0.0, deg2rad(25))),
      "turn the part 15 deg counter-clockwise (seen from above) and move it 50 mm towards the robot and "
      "30 mm to the robot's left");
}

// The straight torch: the cells' former tool, with which many placements near the robot do not weld.
const char* const kStraightTorch = "scenes/robots/aubo_i5_cell.yaml";

TEST(Placement, TheMapSeesNoRoomOutOfReachAndWelds) {
  const Cell cell("scenes/cells/default.yaml", std::nullopt, kStraightTorch);
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  ReachSetting setting;
  setting.grid_m = 0.05;
  setting.yaw_step_rad = deg2rad(90);
  size_t calls = 0;
  const WeldabilityMap map =
      weldability_map(cell.spec, cell.part, cell.robot, mesh, setting, [&](size_t, size_t) { ++calls; });
  ASSERT_EQ(map.nx, 17u);  // x -0.12 .. 0.68
  ASSERT_EQ(map.ny, 25u);  // y -0.60 .. 0.60
  ASSERT_EQ(map.nyaw, 4u);
  EXPECT_GE(calls, 1u);
  // The table's corner (the plate hangs off), the robot's base.
  EXPECT_EQ(map.at(16, 0, 0).kind, PlacementKind::kNoRoom);  // (0.68, -0.6): hangs off the table
  EXPECT_EQ(map.at(4, 12, 0).kind, PlacementKind::kNoRoom);  // (0.08, 0): on the robot base
  size_t welds = 0, unreachable = 0, collides = 0;
  for (const MapPlacement& p : map.placements) {
    // Each kind with its reason, as the planner gave it.
    if (p.kind == PlacementKind::kOutOfReach) {
      EXPECT_NE(p.reason.find("out of reach"), std::string::npos) << p.reason;
      ++unreachable;
    } else if (p.kind == PlacementKind::kCollides) {
      EXPECT_NE(p.reason.find("collides"), std::string::npos) << p.reason;
      ++collides;
    } else if (p.kind == PlacementKind::kWelds) {
      EXPECT_EQ(p.reason, "");
      ++welds;
    } else {
      EXPECT_FALSE(p.reason.empty());
    }
  }
  EXPECT_GE(welds, 3u);
  EXPECT_GE(unreachable + collides, 1u);
  EXPECT_EQ(map.count(PlacementKind::kWelds), welds);
}

TEST(Placement, TheSuggestionWeldsWhereThePartDoesNot) {
  // The default cell's seed 11 with the straight torch: the upper arm meets the table top on seam 'back'.
  const Cell cell("scenes/cells/default.yaml", 11, kStraightTorch);
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  {
    const WeldPlan plan = plan_in(*cell.world, cell.part, mesh, cell.robot, cell.layout.T_base_part);
    ASSERT_FALSE(plan.ok()) << "the seed no longer fails where it lies: pick another";
    EXPECT_EQ(plan.failure, PlanFailure::kCollides) << plan.problems.front();
  }
  const PlacementSuggestion s =
      suggest_placement(cell.spec, cell.part, cell.robot, mesh, cell.layout, z_symmetry_order(mesh));
  ASSERT_TRUE(s.found) << s.reason;
  EXPECT_GE(s.verified, 1);
  EXPECT_FALSE(s.instruction.empty());
  // The suggestion, applied by a test of its own: the same clamps and clutter, the part moved; it fits,
  // plans and replays clean.
  CellSpec spec = cell.spec;
  spec.placement.area = PlacementSpec::Area::kTable;
  spec.clamp_sites.clear();
  for (const ClampPlacement& c : cell.layout.clamps) spec.clamp_sites.push_back(c.site);
  spec.clutter = cell.layout.clutter;
  const CellLayout moved = layout_at(spec, cell.part, s.T_base_part);
  EXPECT_EQ(layout_problem(spec, cell.part, moved), "");
  const MujocoWorld world(spec, cell.part, cell.robot, moved);
  const WeldPlan plan = plan_in(world, cell.part, mesh, cell.robot, moved.T_base_part);
  ASSERT_TRUE(plan.ok()) << plan.problems.front();
  const ReplayResult replay = replay_plan(world, cell.robot, plan, cell.part, mesh, moved.T_base_part);
  EXPECT_TRUE(replay.passed()) << replay.failures.front();
  // Put down off as an operator would, up to 10 mm along x and y (the corners of that square) and turned 5
  // deg either way: the stations, approach and departure are still reached clear of the cell.
  const GuidanceSetting tolerance;
  for (const auto& [dx, dy, turn] : std::vector<std::array<double, 3>>{
           {1, 1, 0}, {1, -1, 0}, {-1, 1, 0}, {-1, -1, 0}, {0, 0, 1}, {0, 0, -1}}) {
    Iso3 put = s.T_base_part;
    put.translation() += tolerance.placement_tolerance_m * Vec3(dx, dy, 0);
    put.linear() = Eigen::AngleAxisd(turn * tolerance.placement_tolerance_rad, Vec3::UnitZ()) * put.linear();
    const CellLayout off = layout_at(spec, cell.part, put);
    if (!layout_problem(spec, cell.part, off).empty()) continue;  // no room there: not a place to put it
    const MujocoWorld off_world(spec, cell.part, cell.robot, off);
    const WeldPlan quick = plan_in(off_world, cell.part, mesh, cell.robot, off.T_base_part, true);
    EXPECT_TRUE(quick.ok()) << dx << " " << dy << " " << turn << ": " << quick.problems.front();
  }
  // What it says is what it is: the move and the turn.
  EXPECT_NEAR(s.move_m, (s.T_base_part.translation() - cell.layout.T_base_part.translation()).norm(), 1e-9);
  EXPECT_NEAR(std::remainder(yaw_of(s.T_base_part) - yaw_of(cell.layout.T_base_part) - s.turn_rad, 2 * kPi),
              0.0, 1e-9);
  EXPECT_EQ(s.instruction, placement_instruction(cell.layout.T_base_part, s.T_base_part));
}

TEST(Placement, StationsOnlyPassesWhereTheFullPlanDoes) {
  // The quick test is necessary for a plan: wherever the full planner welds, it must pass.
  int full_ok = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    const Cell cell("scenes/cells/default.yaml", seed);
    const Mesh mesh = load_mesh(cell.part.mesh_path);
    const WeldPlan full = plan_in(*cell.world, cell.part, mesh, cell.robot, cell.layout.T_base_part);
    const WeldPlan quick = plan_in(*cell.world, cell.part, mesh, cell.robot, cell.layout.T_base_part, true);
    if (full.ok()) {
      ++full_ok;
      EXPECT_TRUE(quick.ok()) << seed << ": " << quick.problems.front();
    }
    EXPECT_LE(quick.samples.size(), 1u) << "stations only: no trajectory";
  }
  EXPECT_GE(full_ok, 2);
}

}  // namespace
}  // namespace weldtwin
