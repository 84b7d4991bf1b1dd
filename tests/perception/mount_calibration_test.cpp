// The LiDAR mount calibration, checked in the twin: the calibration cell swept through a deliberately wrong
// mount (the twin's LiDAR bracket off by millimetres and tenths of a degree), the mount recovered from that
// sweep alone within 0.5 mm and 0.1 deg; the right mount comes back as no correction; a sweep without the box
// is refused.
#include "perception/mount_calibration.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "core/error.hpp"
#include "sim/sweep_sim.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

ScanLog sweep_with_mount(const test::Cell& cell, const Iso3& delta, uint64_t seed) {
  const RobotModel real = cell.robot.with_mount_offset("lidar", delta);
  const MujocoWorld world(cell.spec, cell.part, real, cell.layout);
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, real);
  LidarSetting lidar;
  lidar.seed = seed;
  return simulate_sweep(world, real, program, lidar).log;
}

Iso3 make_delta(const Vec3& t_m, const Vec3& rpy_deg) {
  Iso3 d = Iso3::Identity();
  d.translate(t_m);
  d.rotate(Eigen::AngleAxisd(deg2rad(rpy_deg.z()), Vec3::UnitZ()) *
           Eigen::AngleAxisd(deg2rad(rpy_deg.y()), Vec3::UnitY()) *
           Eigen::AngleAxisd(deg2rad(rpy_deg.x()), Vec3::UnitX()));
  return d;
}

TEST(MountCalibration, RecoversAPerturbedMountInTheTwin) {
  const test::Cell cell("scenes/cells/calibration.yaml");
  const std::pair<Vec3, Vec3> mounts[] = {{Vec3(0.002, -0.0015, 0.001), Vec3(0.4, -0.3, 0.5)},
                                          {Vec3(-0.001, 0.002, -0.002), Vec3(-0.5, 0.2, -0.3)},
                                          {Vec3::Zero(), Vec3::Zero()}};
  uint64_t seed = 11;
  for (const auto& [t, rpy] : mounts) {
    const Iso3 truth = make_delta(t, rpy);
    const ScanLog log = sweep_with_mount(cell, truth, seed++);
    const MountCalibration cal = calibrate_mount(log, cell.robot);
    const double dt = (cal.delta.translation() - truth.translation()).norm();
    const double dr = rad2deg(Eigen::AngleAxisd(cal.delta.linear().transpose() * truth.linear()).angle());
    std::printf("mount (%g, %g, %g) mm, (%g, %g, %g) deg: recovered within %.3f mm, %.4f deg (rms %.2f mm)\n",
                1e3 * t.x(), 1e3 * t.y(), 1e3 * t.z(), rpy.x(), rpy.y(), rpy.z(), 1e3 * dt, dr,
                1e3 * cal.rms_m);
    EXPECT_LT(dt, 0.0005) << "translation off by " << 1e3 * dt << " mm for " << t.transpose();
    EXPECT_LT(dr, 0.1) << "rotation off by " << dr << " deg for " << rpy.transpose();
    EXPECT_LT((cal.T_base_box.translation() - cell.layout.T_base_part.translation()).norm(), 0.001);
    EXPECT_GT(cal.table_points, 1000);
    EXPECT_GT(cal.box_points, 1000);
  }
}

TEST(MountCalibration, RefusesASweepWithoutTheBox) {
  const test::Cell cell("scenes/cells/default.yaml");  // a tube on a plate, no calibration box
  const ScanLog log = sweep_with_mount(cell, Iso3::Identity(), 3);
  EXPECT_THROW(calibrate_mount(log, cell.robot, {}, "default sweep"), InputError);
}

}  // namespace
}  // namespace weldtwin
