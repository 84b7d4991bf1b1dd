#include "core/robot_model.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "core/error.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

TEST(RobotModel, FlangeAtZeroMatchesThePublishedCheckValue) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const Iso3 T = robot.forward_kinematics(JointVector::Zero(), robot.require_link("flange"));
  EXPECT_NEAR(T.translation().x(), 0.0, 1e-12);
  EXPECT_NEAR(T.translation().y(), -0.2155, 1e-12);
  EXPECT_NEAR(T.translation().z(), 1.0085, 1e-12);
}

TEST(RobotModel, HasTheArmTheToolAndTheSensor) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  EXPECT_EQ(robot.dof(), 6);
  for (const char* link : {"base_link", "wrist2_Link", "flange", "tcp", "lidar"})
    EXPECT_GE(robot.link_index(link), 0) << link;
  // The LiDAR rides on link 5 (wrist2): J6 must not move it, J5 must.
  JointVector q = JointVector::Constant(0.3);
  const int lidar = robot.require_link("lidar");
  const Iso3 a = robot.forward_kinematics(q, lidar);
  q[5] += 1.0;
  EXPECT_TRUE(robot.forward_kinematics(q, lidar).isApprox(a, 1e-12));
  q[4] += 1.0;
  EXPECT_FALSE(robot.forward_kinematics(q, lidar).isApprox(a, 1e-6));
  // The TCP is the stick-out point on the torch axis, 0.25 m from the flange face along +z.
  const Iso3 T_flange_tcp = robot.forward_kinematics(q, robot.require_link("flange")).inverse() *
                            robot.forward_kinematics(q, robot.require_link("tcp"));
  EXPECT_TRUE(T_flange_tcp.translation().isApprox(Vec3(0, 0, 0.25), 1e-12));
}

TEST(RobotModel, SingleLinkFkEqualsTreeFk) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  std::mt19937_64 rng(7);
  std::vector<Iso3> all;
  for (int k = 0; k < 200; ++k) {
    const JointVector q = test::random_q(robot, rng);
    robot.forward_kinematics(q, all);
    for (size_t l = 0; l < all.size(); ++l)
      EXPECT_TRUE(robot.forward_kinematics(q, static_cast<int>(l)).isApprox(all[l], 1e-12));
  }
}

TEST(RobotModel, LimitsAreTheDatasheetFigures) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(robot.upper()[j], deg2rad(175.0), 1e-9);
    EXPECT_NEAR(robot.lower()[j], -deg2rad(175.0), 1e-9);
    EXPECT_DOUBLE_EQ(robot.max_velocity()[j], j < 3 ? 2.5 : 3.2);
    EXPECT_DOUBLE_EQ(robot.max_acceleration()[j], j < 3 ? 17.2 : 20.7);
  }
}

TEST(RobotModel, BadFilesAreInputErrorsNamingTheFile) {
  EXPECT_THROW(RobotModel::load("/nonexistent/robot.urdf"), InputError);
  EXPECT_THROW(RobotModel::from_string("", "empty.urdf"), InputError);
  EXPECT_THROW(RobotModel::from_string("<robot name='x'><link name='a'>", "cut.urdf"), InputError);
  try {
    RobotModel::from_string("<robot name='x'><link name='a'/></robot>", "tiny.urdf");
    FAIL() << "a robot without joints was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tiny.urdf"), std::string::npos);
  }
}

// A description nested 100,000 deep had overflowed the XML parser's stack; now refused before parsing.
// Comments and self-closing elements do not count as levels.
TEST(RobotModel, DeeplyNestedXmlIsRefusedBeforeParsing) {
  std::string deep = "<?xml version=\"1.0\"?>\n<robot name=\"r\">";
  for (int i = 0; i < 5000; ++i) deep += "<link name=\"l\">";
  for (int i = 0; i < 5000; ++i) deep += "</link>";
  deep += "</robot>";
  try {
    RobotModel::from_string(deep, "deep.urdf");
    FAIL() << "parsed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("deep.urdf: elements nested 5001 deep"), std::string::npos)
        << e.what();
  }
  // The shipped arm with a comment full of opening tags: comments are no levels.
  std::ifstream in(test::repo("scenes/robots/aubo_i5.urdf"));
  std::string arm((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string comment = "<!-- ";
  for (int i = 0; i < 100; ++i) comment += "<a>";
  arm.insert(arm.find('>', arm.find("<robot")) + 1, comment + " -->");
  EXPECT_EQ(RobotModel::from_string(arm, "commented.urdf").joint_names().size(), 6u);
}

}  // namespace
}  // namespace weldtwin
