// The live source: a fake RPLIDAR A2 on a pseudo-terminal scans while the fake Aubo controller runs the
// sweep program; the log has the controller's joint states and the device's turns on one clock, only turns
// within the sweep, the sweep program sent sample for sample; a LiDAR unplugged mid-sweep is a clear error.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "hw/robot_driver.hpp"
#include "hw/scan_source.hpp"
#include "perception/scan_assembly.hpp"
#include "planning/weld_planner.hpp"
#include "tests/support/fake_a2.hpp"
#include "tests/support/fake_aubo.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

struct Rig {
  RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  JointVector start = PlanSetting().home;
  JointVector end = start + (JointVector() << 0.5, 0.1, -0.1, 0.2, 0.3, 0.0).finished();
  SweepProgram program{"test sweep", start, {{"across", end, 1.0}}, 0.2, 200.0, robot};
  test::FakeAubo controller{[this] {
    test::FakeAuboSetting s;
    s.start_q = start;
    return s;
  }()};
  std::unique_ptr<RobotDriver> driver = make_robot_driver(controller.spec(), robot, {}, RobotDriverSetting());

  ScanLog sweep(const std::string& port) {
    driver->connect();
    LiveScanInputs live;
    live.driver = driver.get();
    live.program = &program;
    live.express = false;
    live.spinup_s = 0.0;
    return make_scan_source("lidar:" + port, robot, SimScanInputs(), live)->acquire();
  }
};

TEST(LiveScan, TheLidarScansWhileTheArmSweeps) {
  Rig rig;
  test::FakeA2 lidar;
  const ScanLog log = rig.sweep(lidar.port());
  EXPECT_EQ(log.source, "cell");
  EXPECT_EQ(log.joint_names, rig.robot.joint_names());

  // The controller was sent the sweep program at 200 Hz, sample for sample.
  const std::vector<JointVector> sent = rig.controller.path();
  ASSERT_EQ(sent.size(), 201u);
  for (size_t i = 0; i < sent.size(); ++i)
    EXPECT_EQ(sent[i], rig.program.q(0.005 * static_cast<double>(i))) << "sample " << i;

  // Joint states: from the sweep's start to its end, in time order, about 200 a second.
  ASSERT_GT(log.joints.size(), 150u);
  EXPECT_EQ(log.joints.front().t_s, 0.0);
  for (size_t k = 1; k < log.joints.size(); ++k) ASSERT_GT(log.joints[k].t_s, log.joints[k - 1].t_s);
  EXPECT_LT((log.joints.front().q - rig.start).norm(), 1e-3);  // the first frame after the start
  EXPECT_LT((log.joints.back().q - rig.end).norm(), 1e-9);
  EXPECT_NEAR(log.joints.back().t_s, 1.0, 0.25);

  // Turns: whole (400 nodes), all within the joint states' span, with the fake's ranges.
  ASSERT_GT(log.turns.size(), 10u);
  size_t index = 0;
  for (const LidarTurn& t : log.turns) {
    EXPECT_EQ(t.first, index);
    EXPECT_EQ(t.count, static_cast<uint32_t>(test::FakeA2::kPerTurn));
    index += t.count;
  }
  ASSERT_EQ(index, log.samples.size());
  for (const LidarSample& s : log.samples) {
    ASSERT_GE(s.t_s, 0.0);
    ASSERT_LE(s.t_s, log.joints.back().t_s);
    ASSERT_GE(s.range_m, 0.9995f);
    ASSERT_LE(s.range_m, 1.3995f);
  }
  // And assembly takes it as it takes any log.
  EXPECT_EQ(assemble_scan(log, rig.robot).points_base.size(), log.samples.size());
  EXPECT_EQ(lidar.stops() > 0, true);
}

TEST(LiveScan, ALidarUnpluggedMidSweepIsAClearError) {
  Rig rig;
  test::FakeA2 lidar(test::FakeA2::Health::kGood, 20000);
  try {
    rig.sweep(lidar.port());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(lidar.port()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("gone"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(rig.controller.moving());
}

}  // namespace
}  // namespace weldtwin
