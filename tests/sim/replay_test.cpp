// Replay of weld plans in the twin: a plan made at the true pose lands on the seams; a plan made at a pose
// 2 mm off misses them by 2 mm and fails; a plan driven through a clamp fails with the clamp named.
#include "sim/replay.hpp"

#include <gtest/gtest.h>

#include "planning/ik_aubo.hpp"
#include "sim/collision_check.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

TEST(Replay, DistanceToSeamIsExactForALineAndAnArc) {
  const PartSpec round = PartSpec::load(test::repo("scenes/parts/round_on_plate.yaml"));
  const Iso3 T = planar_pose(0.4, 0.1, 0.0, 0.7);
  for (size_t s = 0; s < round.seams.size(); ++s) {
    const Seam& seam = round.seams[s];
    for (double f : {0.0, 0.3, 0.77, 1.0}) {
      const Vec3 on = T * seam.point_at(f);
      EXPECT_NEAR(distance_to_seam(round, static_cast<int>(s), T, on), 0.0, 1e-6);
      // 3 mm along the reference surface's normal (perpendicular to the seam everywhere).
      const Vec3 off = T * (seam.point_at(f) + 0.003 * seam.normal.normalized());
      EXPECT_NEAR(distance_to_seam(round, static_cast<int>(s), T, off), 0.003, 2e-5);
    }
  }
}

// A part arc (120 deg, clockwise, about a tilted axis) and a line: the closed form against the distance to a
// dense polyline of the seam, at random points near and far, beyond the arc's ends and on its axis.
TEST(Replay, DistanceToSeamMatchesADensePolylineEverywhere) {
  PartSpec part;
  Seam arc;
  arc.kind = Seam::Kind::kArc;
  arc.center = Vec3(0.01, -0.02, 0.03);
  arc.axis = Vec3(0.2, -0.1, 1.0).normalized();
  const Vec3 radial = arc.axis.cross(Vec3::UnitX()).normalized();
  arc.radius_m = 0.04;
  arc.start = arc.center + arc.radius_m * radial;
  arc.sweep_rad = -deg2rad(120.0);
  Seam line;
  line.start = Vec3(-0.05, 0.0, 0.0);
  line.end = Vec3(0.05, 0.02, 0.01);
  part.seams = {arc, line};
  const Iso3 T = planar_pose(0.4, 0.1, 0.0, 0.7);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  for (int s = 0; s < 2; ++s) {
    const Seam& seam = part.seams[static_cast<size_t>(s)];
    std::vector<Vec3> points;
    for (int i = 0; i <= 20000; ++i) points.push_back(seam.point_at(i / 20000.0));
    for (int k = 0; k < 300; ++k) {
      Vec3 q(u(rng), u(rng), u(rng));
      if (k == 0) q = arc.center + 0.02 * arc.axis;  // on the axis
      double dense = 1e9;
      for (size_t i = 1; i < points.size(); ++i) {
        const Vec3 ab = points[i] - points[i - 1];
        const double f = std::clamp((q - points[i - 1]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
        dense = std::min(dense, (points[i - 1] + f * ab - q).norm());
      }
      EXPECT_NEAR(distance_to_seam(part, s, T, T * q), dense, 1e-6) << "seam " << s << " point " << k;
    }
  }
}

// The default cell's plan, made at the part's true pose, checked against the cell and the part (as
// `weldtwin run` plans).
WeldPlan plan_at_true_pose(const test::Cell& cell) {
  PlanSetting setting;
  CollisionChecker checker(*cell.world);
  checker.add_part(load_mesh(cell.part.mesh_path), cell.layout.T_base_part);
  setting.collision = checker;
  return plan_welds(cell.part, cell.layout.T_base_part, cell.robot, setting);
}

TEST(Replay, APlanAtTheTruePoseLandsOnTheSeamsWithoutContacts) {
  const test::Cell cell;
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  const WeldPlan plan = plan_at_true_pose(cell);
  ASSERT_TRUE(plan.ok()) << plan.problems.front();
  const ReplayResult r = replay_plan(*cell.world, cell.robot, plan, cell.part, mesh, cell.layout.T_base_part);
  EXPECT_TRUE(r.passed()) << (r.failures.empty() ? "" : r.failures.front());
  ASSERT_EQ(r.samples.size(), plan.samples.size());
  EXPECT_TRUE(r.contacts.empty());
  EXPECT_LT(r.max_seam_error_m, 2e-4);
  EXPECT_LT(r.max_tracking_rad, deg2rad(0.05));
  // The torch stays clear of the part, but it is close while welding (a few millimetres, not metres).
  EXPECT_GT(r.min_clearance_m, 0.00075);
  EXPECT_LT(r.min_clearance_m, 0.012);
  int arc = 0;
  for (const ReplaySample& s : r.samples) arc += s.arc;
  int counted = 0;
  for (const SeamFigure& f : r.seams) {
    EXPECT_GT(f.samples, 0) << f.name;
    EXPECT_LE(f.rms_error_m, f.max_error_m + 1e-12);
    counted += f.samples;
  }
  EXPECT_EQ(counted, arc);
  // Each sample's TCP is where the URDF puts it for that sample's joints (not the pose a step earlier, which
  // is off by the TCP's travel in a step: tens of micrometres while welding).
  const int tcp = cell.robot.require_link("tcp");
  double worst = 0.0;
  for (const ReplaySample& s : r.samples)
    worst = std::max(worst, (s.tcp - cell.robot.forward_kinematics(s.q, tcp).translation()).norm());
  EXPECT_LT(worst, 1e-9);
}

TEST(PartClearance, StartingFromTheLastNearestPointChangesNoAnswer) {
  const test::Cell cell;
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  const WeldPlan plan = plan_at_true_pose(cell);
  ASSERT_TRUE(plan.ok()) << plan.problems.front();
  const PartClearance clearance(*cell.world, mesh, cell.layout.T_base_part, 0.05);
  DataPtr d(mj_makeData(cell.world->model()));
  PartClearance::Hint hint;
  size_t near = 0;
  for (size_t k = 0; k < plan.samples.size(); k += 3) {
    cell.world->set_joints(d.get(), plan.samples[k].q);
    std::string plain_geom, hinted_geom;
    const double plain = clearance.clearance(d.get(), &plain_geom);
    const double hinted = clearance.clearance(d.get(), &hinted_geom, &hint);
    // The same answer to within Embree's single precision (its point queries prune in float, bounded by the
    // best distance so far, which the hint makes tighter): 10 nm, against clearances judged at 0.25 mm.
    ASSERT_NEAR(plain, hinted, 1e-8) << "sample " << k;
    ASSERT_EQ(plain_geom, hinted_geom) << "sample " << k;
    near += plain < 0.05;
    if (k % 300 == 0) hint = PartClearance::Hint{};  // now and then from nothing again
  }
  EXPECT_GT(near, plan.samples.size() / 10);  // the torch near the part: the hint was in play
}

TEST(PartClearance, EachArmsSurfaceIsMadeOnceAndNeverTakenForAnothers) {
  // The straight torch's arm first, then the swan neck's in two layouts, then the straight one again: each
  // clearance must be its own arm's (a surface shared by mistake answers with the other torch's points).
  const test::Cell straight("scenes/cells/default.yaml", 5, "scenes/robots/aubo_i5_cell.yaml");
  const test::Cell bent("scenes/cells/default.yaml", 5), bent_other_layout("scenes/cells/default.yaml", 9);
  const Mesh mesh = load_mesh(bent.part.mesh_path);
  const Iso3& T = bent.layout.T_base_part;
  const PartClearance a(*straight.world, mesh, T, 0.05), b(*bent.world, mesh, T, 0.05),
      b2(*bent_other_layout.world, mesh, T, 0.05), a2(*straight.world, mesh, T, 0.05);
  EXPECT_NE(a.surface_points(), b.surface_points());
  EXPECT_EQ(b.surface_points(), b2.surface_points());
  EXPECT_EQ(a.surface_points(), a2.surface_points());
  // At the swan neck's weld configurations the arms stand differently close to the part; each answer equals
  // the same arm's in the other layout (the part stands where it stood), never the other arm's.
  const WeldPlan plan = plan_at_true_pose(bent);
  ASSERT_TRUE(plan.ok()) << plan.problems.front();
  DataPtr ds(mj_makeData(straight.world->model())), db(mj_makeData(bent.world->model())),
      db2(mj_makeData(bent_other_layout.world->model()));
  size_t differ = 0;
  for (size_t k = 0; k < plan.samples.size(); k += 50) {
    const JointVector& q = plan.samples[k].q;
    straight.world->set_joints(ds.get(), q);
    bent.world->set_joints(db.get(), q);
    bent_other_layout.world->set_joints(db2.get(), q);
    ASSERT_EQ(b.clearance(db.get()), b2.clearance(db2.get())) << "sample " << k;
    ASSERT_EQ(a.clearance(ds.get()), a2.clearance(ds.get())) << "sample " << k;
    differ += std::abs(a.clearance(ds.get()) - b.clearance(db.get())) > 1e-4;
  }
  EXPECT_GT(differ, 0u);
}

TEST(Replay, APlanFromAPoseTwoMillimetresOffMissesTheSeamsByThatMuch) {
  const test::Cell cell;
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  Iso3 wrong = cell.layout.T_base_part;
  wrong.translation() += Vec3(-0.002, 0.0, 0.0);
  PlanSetting setting;
  setting.collision = CollisionChecker(*cell.world);
  const WeldPlan plan = plan_welds(cell.part, wrong, cell.robot, setting);
  ASSERT_TRUE(plan.ok()) << plan.problems.front();
  const ReplayResult r = replay_plan(*cell.world, cell.robot, plan, cell.part, mesh, cell.layout.T_base_part);
  EXPECT_FALSE(r.passed());
  // Seams along x are not moved by an x shift; those across it are moved by 2 mm.
  EXPECT_NEAR(r.max_seam_error_m, 0.002, 2e-4);
  bool named = false;
  for (const std::string& f : r.failures) named |= f.find("from the true seam") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(CollisionChecker, KeepsTheTorchAMillimetreFromTheCell) {
  const test::Cell cell;
  const CollisionChecker plain(*cell.world, 0.0, 0.0), grown(*cell.world);
  // From home, one joint turned until the torch (and nothing else) meets the cell; the boundary of each
  // checker by bisection.
  const JointVector home = PlanSetting().home;
  JointVector down = home;
  bool found = false;
  for (int j = 1; j < 6 && !found; ++j)
    for (const double step : {0.02, -0.02}) {
      down = home;
      while (plain(down).empty() && std::abs(down[j] - home[j]) < 2.5) down[j] += step;
      if ((found = plain(down).rfind("torch_", 0) == 0)) break;
    }
  ASSERT_TRUE(found);
  auto boundary = [&](const CollisionChecker& c) {
    double lo = 0.0, hi = 1.0;
    for (int k = 0; k < 40; ++k) {
      const double mid = 0.5 * (lo + hi);
      (c(home + mid * (down - home)).empty() ? lo : hi) = mid;
    }
    return lo;
  };
  const double t_plain = boundary(plain), t_grown = boundary(grown);
  ASSERT_LT(t_grown, t_plain);
  // The torch's tip stops short by about the clearance (more, as it does not approach the table head on).
  const int tcp = cell.robot.require_link("tcp");
  const double short_m = (cell.robot.forward_kinematics(home + t_plain * (down - home), tcp).translation() -
                          cell.robot.forward_kinematics(home + t_grown * (down - home), tcp).translation())
                             .norm();
  EXPECT_GT(short_m, 0.001);
  EXPECT_LT(short_m, 0.004);
  EXPECT_NE(grown(home + 0.5 * (t_grown + t_plain) * (down - home)).find("torch_"), std::string::npos);
}

TEST(Replay, APlanThroughAClampFailsWithTheClampNamed) {
  const test::Cell cell;
  ASSERT_FALSE(cell.layout.clamps.empty());
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  // A straight joint-space move from home down through the first clamp's arm, torch pointing down, and back:
  // the arm's outer part (beyond the plate, 22-34 mm above the pad's contact point) with the TCP (the
  // wire's end) 27.5 mm below its middle, which puts the nozzle (15-40 mm above the TCP) into it.
  const Iso3 T_base_clamp = cell.layout.clamps.front().T_base_clamp;
  const Vec3 target = T_base_clamp * Vec3(0.08, 0.0, 0.028 - 0.0275);
  const Iso3 T_base_tcp = make_transform(target, Eigen::AngleAxisd(kPi, Vec3::UnitX()).toRotationMatrix());
  WeldPlan plan;
  const PlanSetting setting;
  const AuboIk ik(cell.robot, "tcp");
  JointVector goal;
  ASSERT_TRUE(ik.nearest(T_base_tcp, setting.home, goal));
  const int n = 1200;  // 6 s at 200 Hz: there and back, smoothly
  for (int k = 0; k <= n; ++k) {
    const double u = 0.5 - 0.5 * std::cos(2 * kPi * k / n);
    PlanSample s;
    s.t_s = k / 200.0;
    s.q = setting.home + u * (goal - setting.home);
    s.T_base_tcp = cell.robot.forward_kinematics(s.q, cell.robot.require_link("tcp"));
    plan.samples.push_back(s);
  }
  const ReplayResult r = replay_plan(*cell.world, cell.robot, plan, cell.part, mesh, cell.layout.T_base_part);
  const ReplaySample& mid = r.samples[r.samples.size() / 2];
  EXPECT_NEAR((mid.tcp_ref - target).norm(), 0.0, 1e-6);
  EXPECT_FALSE(r.passed());
  bool clamp = false;
  for (const ReplayContact& c : r.contacts)
    clamp |= c.other == Label::kClamp && c.other_geom.rfind("clamp0", 0) == 0;
  EXPECT_TRUE(clamp);
  bool named = false;
  for (const std::string& f : r.failures)
    named |= f.find("contact:") == 0 && f.find("clamp0") != std::string::npos;
  EXPECT_TRUE(named) << (r.failures.empty() ? "no failures" : r.failures.front());
}

}  // namespace
}  // namespace weldtwin
