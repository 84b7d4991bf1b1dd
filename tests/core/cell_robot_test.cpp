#include "core/cell_robot.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "core/error.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

std::string write_cell(const std::string& name, const std::string& robot, const std::string& tooling = "") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "weldtwin_cell_robot_test";
  std::filesystem::create_directories(dir);
  const std::string scenes = test::repo("scenes");
  const std::string path = (dir / name).string();
  std::ofstream(path) << "environment: " << scenes << "/cells/default.xml\n"
                      << "robot: " << robot << "\n"
                      << "sweep: " << scenes << "/sweeps/default.yaml\n"
                      << "part: {spec: " << scenes << "/parts/tube_on_plate.yaml}\n"
                      << tooling;
  return path;
}

std::string vendor_urdf() {
  return "{urdf: " + test::repo("scenes/robots/aubo_description/urdf/aubo_i5.urdf") + "}";
}

// The straight-torch robot file (the vendor's description with the tooling declared in it) has the torch tip
// and the LiDAR where weldtwin's own URDF (tooling baked in) puts them.
TEST(CellRobot, VendorUrdfWithCellToolingEqualsOwnUrdf) {
  const RobotModel own =
      load_cell_robot(CellSpec::load(write_cell("own.yaml", test::repo("scenes/robots/aubo_i5.urdf"))));
  const CellSpec cell =
      CellSpec::load(write_cell("straight.yaml", test::repo("scenes/robots/aubo_i5_cell.yaml")));
  ASSERT_EQ(cell.tooling.size(), 4u);
  EXPECT_EQ(std::filesystem::path(cell.robot_urdf).filename(), "aubo_i5.urdf");
  EXPECT_NE(cell.robot_urdf.find("aubo_description"), std::string::npos) << cell.robot_urdf;
  const RobotModel vendor = load_cell_robot(cell);
  EXPECT_NEAR(vendor.upper()[0], 2 * kPi, 1e-12);  // the vendor's limits, not ours
  EXPECT_FALSE(
      vendor.links()[static_cast<size_t>(vendor.require_link("upperArm_Link"))].collision_meshes.empty());
  const RobotLink& torch = vendor.links()[static_cast<size_t>(vendor.require_link("torch"))];
  ASSERT_EQ(torch.collision.size(), 3u);
  EXPECT_NEAR(torch.collision[2].size.x(), 0.010, 1e-15);
  EXPECT_NEAR(torch.inertial.mass_kg, 0.9, 1e-12);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int i = 0; i < 100; ++i) {
    JointVector q;
    for (int k = 0; k < 6; ++k) q[k] = u(rng);
    for (const char* link : {"flange", "tcp", "lidar"}) {
      const Iso3 a = own.forward_kinematics(q, own.require_link(link));
      const Iso3 b = vendor.forward_kinematics(q, vendor.require_link(link));
      EXPECT_LT((a.translation() - b.translation()).norm(), 1e-9) << link;
      EXPECT_LT((a.linear() - b.linear()).norm(), 1e-9) << link;
    }
  }
}

// Cells share a robot file; a cell's own tooling comes after the file's, on its links.
TEST(CellRobot, ACellAddsItsToolingToTheRobotFile) {
  const std::string cell = write_cell("extra.yaml", test::repo("scenes/robots/aubo_i5_cell.yaml"),
                                      "tooling: [{link: wire_feeder, parent: torch, xyz_mm: [0, 40, 20]}]\n");
  const CellSpec spec = CellSpec::load(cell);
  ASSERT_EQ(spec.tooling.size(), 5u);
  EXPECT_EQ(spec.tooling.front().link, "flange");
  EXPECT_EQ(spec.tooling.back().link, "wire_feeder");
  const RobotModel robot = load_cell_robot(spec);
  const JointVector q = JointVector::Constant(0.3);
  const Iso3 feeder = robot.forward_kinematics(q, robot.require_link("wire_feeder"));
  const Iso3 torch = robot.forward_kinematics(q, robot.require_link("torch"));
  EXPECT_LT((feeder.translation() - torch * Vec3(0, 0.04, 0.02)).norm(), 1e-12);
  // A robot file that is no mapping, or names no URDF, is refused naming the robot file.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "weldtwin_cell_robot_test";
  std::ofstream(dir / "bad_robot.yaml") << "tooling: []\n";
  try {
    CellSpec::load(write_cell("bad.yaml", (dir / "bad_robot.yaml").string()));
    ADD_FAILURE() << "a robot file without urdf was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad_robot.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("urdf"), std::string::npos) << e.what();
  }
}

// The swan-neck torches, 22 and 45 deg (robot files a cell can take instead of its own): the TCP, found by FK
// through the tooling links, lies where the neck's geometry puts it, computed here from the flange alone:
// 120 mm along the flange axis to the bend, then 150 mm (110 neck, 25 nozzle, 15 stick-out) along the flange
// axis turned by the bend about the flange's x; the TCP's z is the bent axis, and the nozzle ends 15 mm
// before the TCP.
class SwanNeck : public ::testing::TestWithParam<int> {};

TEST_P(SwanNeck, TheTcpLiesAtTheEndOfItsBentNeck) {
  const int bend_deg = GetParam();
  CellSpec cell = CellSpec::load(test::repo("scenes/cells/default.yaml"));
  cell.use_robot_file(test::repo("scenes/robots/aubo_i5_bent" + std::to_string(bend_deg) + "_cell.yaml"));
  ASSERT_EQ(cell.tooling.size(), 4u);  // the robot file's tooling replaces the cell's
  const RobotModel robot = load_cell_robot(cell);
  const RobotLink& torch = robot.links()[static_cast<size_t>(robot.require_link("torch"))];
  EXPECT_NEAR(torch.inertial.mass_kg, 1.1, 1e-12);
  ASSERT_EQ(torch.collision.size(), 5u);
  const LinkGeometry& nozzle = torch.collision.back();
  ASSERT_EQ(nozzle.type, LinkGeometry::Type::kCylinder);
  const double bend = deg2rad(bend_deg);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int i = 0; i < 50; ++i) {
    JointVector q;
    for (int k = 0; k < 6; ++k) q[k] = u(rng);
    const Iso3 flange = robot.forward_kinematics(q, robot.require_link("flange"));
    const Vec3 axis = flange.linear() * Vec3(0.0, -std::sin(bend), std::cos(bend));
    const Vec3 tip = flange * Vec3(0, 0, 0.120) + 0.150 * axis;
    const Iso3 tcp = robot.forward_kinematics(q, robot.require_link("tcp"));
    EXPECT_LT((tcp.translation() - tip).norm(), 2e-6);
    EXPECT_LT((tcp.linear().col(2) - axis).norm(), 1e-9);
    EXPECT_NEAR(std::acos(tcp.linear().col(2).dot(flange.linear().col(2))), bend, 1e-9);
    // The nozzle: a cylinder along the bent axis whose end face is 15 mm short of the TCP.
    const Iso3 link = robot.forward_kinematics(q, robot.require_link("torch"));
    const Iso3 geom = link * nozzle.T_link_geom;
    EXPECT_LT((geom.linear().col(2) - axis).norm(), 1e-6);
    EXPECT_LT((geom.translation() + 0.5 * nozzle.size.y() * axis - (tip - 0.015 * axis)).norm(), 2e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(CellRobot, SwanNeck, ::testing::Values(22, 45));

std::string load_error(const std::string& path) {
  try {
    load_cell_robot(CellSpec::load(path));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(CellRobot, ToolingThatDoesNotFitTheRobotIsRefusedNamingTheCell) {
  const std::string unknown =
      write_cell("unknown.yaml", vendor_urdf(), "tooling: [{link: torch, parent: wrist9_Link}]\n");
  EXPECT_NE(load_error(unknown).find("unknown.yaml"), std::string::npos) << load_error(unknown);
  EXPECT_NE(load_error(unknown).find("parent link 'wrist9_Link'"), std::string::npos) << load_error(unknown);
  const std::string twice =
      write_cell("twice.yaml", vendor_urdf(), "tooling: [{link: wrist3_Link, parent: wrist2_Link}]\n");
  EXPECT_NE(load_error(twice).find("already has a link"), std::string::npos) << load_error(twice);
  const std::string xml =
      write_cell("xml.yaml", vendor_urdf(), "tooling: [{link: 'a\"/><x', parent: wrist3_Link}]\n");
  EXPECT_THROW(CellSpec::load(xml), InputError);
  const std::string shape = write_cell(
      "shape.yaml", vendor_urdf(),
      "tooling: [{link: t, parent: wrist3_Link, shapes: [{type: cylinder, radius_m: -1, length_m: 1}]}]\n");
  EXPECT_THROW(CellSpec::load(shape), InputError);
}

}  // namespace
}  // namespace weldtwin
