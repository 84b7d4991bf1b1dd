// Scan assembly through FK of logged joint states reproduces the twin's own sensor poses: exactly when joints
// are logged at every sample, within the interpolation bound when they are logged at 200 Hz.
#include "perception/scan_assembly.hpp"

#include <gtest/gtest.h>

#include "sim/sweep_sim.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

struct Assembled {
  SweepResult sweep;
  AssembledCloud by_fk, by_sim;
};

Assembled run(const test::Cell& cell, const SweepProgram& program, double joint_log_hz) {
  SweepOptions options;
  options.record_sensor_poses = true;
  options.max_duration_s = 18.0;  // a whole pass and a transition: constant velocity and blends
  options.joint_log_hz = joint_log_hz;
  Assembled a;
  a.sweep = simulate_sweep(*cell.world, cell.robot, program, LidarSetting(), options);
  a.by_fk = assemble_scan(a.sweep.log, cell.robot);
  a.by_sim = assemble_scan(a.sweep.log, a.sweep.T_base_lidar);
  return a;
}

TEST(ScanAssembly, JointsLoggedAtEverySampleGiveTheSimCloudWithin1nm) {
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  const Assembled a = run(cell, program, LidarSetting().sample_rate_hz);
  ASSERT_EQ(a.by_fk.points_base.size(), a.by_sim.points_base.size());
  ASSERT_GT(a.by_fk.points_base.size(), 10000u);
  double worst = 0.0;
  for (size_t i = 0; i < a.by_fk.points_base.size(); ++i)
    worst = std::max(worst, (a.by_fk.points_base[i] - a.by_sim.points_base[i]).norm());
  std::printf("joints at every sample: worst difference %.2e m over %zu points\n", worst,
              a.by_fk.points_base.size());
  EXPECT_LT(worst, 1e-9);
}

TEST(ScanAssembly, JointsLoggedAt200HzStayWithinTheInterpolationBound) {
  // Linear interpolation of a joint with |qdd| <= A between states dt apart errs by at most A dt^2 / 8; a
  // joint error dq moves a point at distance rho from that joint's axis by at most rho |dq|. The bound per
  // point is A dt^2 / 8 * sum_j |p - o_j|, o_j a point on joint j's axis.
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  const double hz = 200.0, dt = 1.0 / hz;
  const Assembled a = run(cell, program, hz);
  ASSERT_EQ(a.by_fk.points_base.size(), a.by_sim.points_base.size());
  const double dq = program.max_abs_acceleration() * dt * dt / 8.0;
  std::vector<Iso3> fk;
  double worst = 0.0, worst_ratio = 0.0;
  for (size_t i = 0; i < a.by_fk.points_base.size(); ++i) {
    const Vec3& p = a.by_sim.points_base[i];
    cell.robot.forward_kinematics(program.q(a.sweep.log.samples[a.by_sim.sample_index[i]].t_s), fk);
    double lever = 0.0;
    for (size_t l = 0; l < fk.size(); ++l)
      if (cell.robot.links()[l].q_index >= 0) lever += (p - fk[l].translation()).norm();
    const double err = (a.by_fk.points_base[i] - p).norm();
    const double bound = dq * lever + 1e-9;
    EXPECT_LE(err, bound) << "point " << i;
    worst = std::max(worst, err);
    worst_ratio = std::max(worst_ratio, err / bound);
  }
  std::printf("joints at %.0f Hz: worst difference %.2e m, %.1f %% of its bound (joint bound %.1e rad)\n", hz,
              worst, 100 * worst_ratio, dq);
  EXPECT_GT(worst, 1e-9);  // the effect is real, not zero by accident
}

TEST(ScanAssembly, PosesAtKnotsInterpolatedGiveTheCloudOfPosesAtEverySampleWithin1um) {
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  const Assembled a = run(cell, program, 200.0);
  AssemblySetting every;
  every.knot_samples = 1;
  const AssembledCloud exact = assemble_scan(a.sweep.log, cell.robot, every);
  ASSERT_EQ(exact.points_base.size(), a.by_fk.points_base.size());
  double worst = 0.0, worst_view = 0.0;
  for (size_t i = 0; i < exact.points_base.size(); ++i) {
    ASSERT_EQ(exact.sample_index[i], a.by_fk.sample_index[i]);
    worst = std::max(worst, (exact.points_base[i] - a.by_fk.points_base[i]).norm());
    worst_view = std::max(worst_view, (exact.viewpoints_base[i] - a.by_fk.viewpoints_base[i]).norm());
  }
  std::printf("knots every 8 samples: worst difference %.2e m (sensor %.2e m)\n", worst, worst_view);
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(worst_view, 0.0);  // interpolated, not posed exactly
  EXPECT_LT(worst_view, 1e-6);

  // A gap in the log (samples lost for 50 ms): the knots around it are too far apart, every sample there is
  // posed exactly — the same points as without knots.
  ScanLog gap = a.sweep.log;
  for (size_t i = 4000; i < gap.samples.size(); ++i) gap.samples[i].t_s += 0.05;
  for (JointState& j : gap.joints)
    if (j.t_s > gap.samples[3999].t_s) j.t_s += 0.05;
  const AssembledCloud gap_knots = assemble_scan(gap, cell.robot),
                       gap_exact = assemble_scan(gap, cell.robot, every);
  ASSERT_EQ(gap_knots.points_base.size(), gap_exact.points_base.size());
  for (size_t i = 0; i < gap_knots.points_base.size(); ++i)
    ASSERT_LT((gap_knots.points_base[i] - gap_exact.points_base[i]).norm(), 1e-6) << i;
}

TEST(ScanAssembly, InterpolationIsLinearAndRefusesToExtrapolate) {
  std::vector<JointState> joints = {{0.0, JointVector::Zero()}, {1.0, JointVector::Constant(2.0)}};
  JointVector q;
  ASSERT_TRUE(interpolate_joints(joints, 0.25, q));
  EXPECT_TRUE(q.isApprox(JointVector::Constant(0.5)));
  EXPECT_FALSE(interpolate_joints(joints, 1.5, q));
  EXPECT_FALSE(interpolate_joints(joints, -0.1, q));
}

}  // namespace
}  // namespace weldtwin
