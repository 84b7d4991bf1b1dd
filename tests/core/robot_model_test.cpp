#include "core/robot_model.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <vector>

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

TEST(RobotModel, CachedChainFkEqualsTreeFkWhateverJointsChange) {
  // Our arm turns every joint about z; a made-up arm with x, y and skewed axes and a fixed link at the end
  // covers the other branch. One cache is shared by all links in turn (it must notice the link changed).
  const char* twisted = R"(<robot name="twisted">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.1"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.2 0 0" rpy="0.3 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0.2 0"/>
    <axis xyz="0.6 0 0.8"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j4" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="d"/><link name="e"/><link name="f"/>
  <joint name="j5" type="revolute"><parent link="d"/><child link="e"/><origin xyz="0.1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j6" type="revolute"><parent link="e"/><child link="f"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 -1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="fix" type="fixed"><parent link="f"/><child link="tip"/><origin xyz="0.01 0.02 0.3" rpy="0.1 0.2 0.3"/></joint>
</robot>)";
  const RobotModel aubo = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const RobotModel made_up = RobotModel::from_string(twisted, "twisted.urdf");
  for (const RobotModel* robot : {&aubo, &made_up}) {
    const RobotModel offset = robot->with_mount_offset(
        robot->links().back().name,
        make_transform(Vec3(0.004, -0.003, 0.002), Mat3(Eigen::AngleAxisd(0.01, Vec3::UnitY()))));
    for (const RobotModel* r : {robot, &offset}) {
      std::mt19937_64 rng(5);
      RobotModel::ChainCache cache;
      std::vector<Iso3> all;
      JointVector q = test::random_q(*r, rng);
      for (int k = 0; k < 600; ++k) {
        const JointVector fresh = test::random_q(*r, rng);
        const int j = k % 7;  // one joint changes, or (6) all of them
        if (j < 6)
          q[j] = fresh[j];
        else
          q = fresh;
        r->forward_kinematics(q, all);
        const int link = (k / 7) % static_cast<int>(all.size());
        const Iso3 T = r->forward_kinematics(q, link, cache);
        EXPECT_LT((T.translation() - all[static_cast<size_t>(link)].translation()).norm(), 1e-13)
            << r->name() << " link " << link << " step " << k;
        EXPECT_LT((T.linear() - all[static_cast<size_t>(link)].linear()).cwiseAbs().maxCoeff(), 1e-13)
            << r->name() << " link " << link << " step " << k;
      }
    }
  }
  RobotModel::ChainCache cache;
  EXPECT_THROW(aubo.forward_kinematics(JointVector::Zero(), -1, cache), std::out_of_range);
  EXPECT_THROW(aubo.forward_kinematics(JointVector::Zero(), 1000, cache), std::out_of_range);
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

// The vendor's own description (scenes/robots/aubo_description, as its ROS package ships it): meshes through
// package://, vendor-only elements ignored with a note, its joint limits, and the same kinematic chain as
// ours: every arm link's pose equal within 1e-9 m and 1e-9 rad at 200 random joint vectors.
TEST(RobotModel, TheVendorsDescriptionLoadsWithItsMeshesAndLimitsAndOurKinematics) {
  const std::string urdf = test::repo("scenes/robots/aubo_description/urdf/aubo_i5.urdf");
  const RobotModel vendor = RobotModel::load(urdf);
  const RobotModel ours = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  ASSERT_EQ(vendor.joint_names(), ours.joint_names());
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(vendor.lower()[j], -2 * kPi, 1e-12);
    EXPECT_NEAR(vendor.upper()[j], 2 * kPi, 1e-12);
    EXPECT_DOUBLE_EQ(vendor.max_velocity()[j], j < 3 ? 2.5964 : 3.1105);  // rad/s, as the file gives
  }
  std::string notes;
  for (const std::string& n : vendor.notes()) notes += n + "\n";
  for (const char* n : {"ignored <dh_type>: not an element of URDF", "ignored <safety_para>",
                        "ignored <friction_coeff>", "ignored <property> (6 times)"})
    EXPECT_NE(notes.find(n), std::string::npos) << n << " in\n" << notes;
  EXPECT_EQ(ours.notes().size(), 0u) << ours.notes().front();
  // Every link's meshes, found through the package's folder.
  size_t meshes = 0;
  for (const RobotLink& l : vendor.links()) {
    for (const LinkMesh& m : l.collision_meshes) {
      ++meshes;
      EXPECT_TRUE(std::filesystem::is_regular_file(m.path)) << m.path;
      EXPECT_NE(m.path.find("aubo_description/meshes/aubo_i5/collision/"), std::string::npos) << m.path;
    }
    EXPECT_EQ(l.collision_meshes.size(), l.visual_meshes.size()) << l.name;
  }
  EXPECT_EQ(meshes, 7u);
  // The same chain: the vendor's root is a `world` link above base_link.
  const int vendor_base = vendor.require_link("base_link");
  std::mt19937_64 rng(11);
  double worst_m = 0, worst_rad = 0;
  for (int k = 0; k < 200; ++k) {
    const JointVector q = test::random_q(ours, rng);
    const Iso3 T_world_base = vendor.forward_kinematics(q, vendor_base);
    for (const char* link :
         {"shoulder_Link", "upperArm_Link", "foreArm_Link", "wrist1_Link", "wrist2_Link", "wrist3_Link"}) {
      const Iso3 a = T_world_base.inverse() * vendor.forward_kinematics(q, vendor.require_link(link));
      const Iso3 b = ours.forward_kinematics(q, ours.require_link(link));
      worst_m = std::max(worst_m, (a.translation() - b.translation()).norm());
      worst_rad = std::max(worst_rad, Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle());
    }
  }
  EXPECT_LT(worst_m, 1e-9);
  EXPECT_LT(worst_rad, 1e-9);
}

TEST(RobotModel, AMeshWhosePackageOrFileIsMissingIsRefusedNamingIt) {
  const std::string link =
      "<link name='a'/><joint name='j' type='revolute'><parent link='a'/><child link='b'/>"
      "<axis xyz='0 0 1'/><limit lower='-1' upper='1' velocity='1' effort='1'/></joint>";
  auto robot = [&](const std::string& mesh) {
    std::string xml = "<robot name='r'>" + link + "<link name='b'><collision><geometry><mesh filename='" +
                      mesh + "'/></geometry></collision></link>";
    for (int k = 0; k < 5; ++k) {  // five more joints: a 6-joint arm
      const std::string p = k == 0 ? "b" : "c" + std::to_string(k - 1), c = "c" + std::to_string(k);
      xml += "<link name='" + c + "'/><joint name='j" + c + "' type='revolute'><parent link='" + p +
             "'/><child link='" + c +
             "'/><axis xyz='0 0 1'/><limit lower='-1' upper='1' velocity='1' "
             "effort='1'/></joint>";
    }
    return xml + "</robot>";
  };
  auto error = [&](const std::string& mesh) {
    try {
      RobotModel::from_string(robot(mesh), "/tmp/r.urdf");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error("package://no_such_package/m.stl").find("package 'no_such_package' not found"),
            std::string::npos);
  EXPECT_NE(error("missing_mesh.stl").find("mesh missing_mesh.stl is not there (/tmp/missing_mesh.stl)"),
            std::string::npos);
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
