// The files weldtwin writes and other tools read (pose, plan, LiDAR mount): what one writer writes, its one
// reader reads back the same; what is not one of them is refused naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

#include "app/json_file.hpp"
#include "app/mount_file.hpp"
#include "app/plan_file.hpp"
#include "app/pose_file.hpp"
#include "core/cell_robot.hpp"
#include "perception/localizer.hpp"
#include "tests/input_error_of.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using test::input_error_of;

std::string temp_path(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_file_formats_test";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string written(const std::string& name, const std::string& text) {
  const std::string path = temp_path(name);
  std::ofstream(path) << text;
  return path;
}

Iso3 random_pose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3 axis = Vec3(u(rng), u(rng), u(rng)).normalized();
  return make_transform(Vec3(u(rng), u(rng), 0.1 * u(rng)), Eigen::AngleAxisd(3.0 * u(rng), axis).matrix());
}

TEST(PoseFile, WhatIsWrittenIsReadBack) {
  std::mt19937_64 rng(7);
  for (int k = 0; k < 20; ++k) {
    PoseEstimate pose;
    pose.found = true;
    pose.T_base_part = random_pose(rng);
    const std::string path = temp_path("pose.json");
    write_json_file(path, pose_to_json(pose));
    const Iso3 back = read_pose(path);
    EXPECT_LT((back.matrix() - pose.T_base_part.matrix()).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
  // The truth file is a pose file too.
  const Iso3 T = random_pose(rng);
  write_json_file(temp_path("truth.json"), true_pose_json(T));
  EXPECT_LT((read_pose(temp_path("truth.json")).matrix() - T.matrix()).norm(), 1e-12);
}

TEST(PoseFile, NotFoundAndNotRigidAreRefused) {
  PoseEstimate lost;
  lost.found = false;
  lost.reason = "the best match covers too little of the model";
  write_json_file(temp_path("lost.json"), pose_to_json(lost));
  const std::string why = input_error_of([&] { read_pose(temp_path("lost.json")); });
  EXPECT_NE(why.find("lost.json"), std::string::npos) << why;
  EXPECT_NE(why.find("not found (the best match covers too little"), std::string::npos) << why;

  nlohmann::json scaled = true_pose_json(Iso3::Identity());
  scaled["T_base_part"][0][0] = 1.01;
  write_json_file(temp_path("scaled.json"), scaled);
  EXPECT_NE(input_error_of([&] { read_pose(temp_path("scaled.json")); }).find("not a rigid transform"),
            std::string::npos);
  const std::string rows = written("rows.json", R"({"T_base_part": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]})");
  EXPECT_NE(input_error_of([&] { read_pose(rows); }).find("must be a 4x4 array"), std::string::npos);
  EXPECT_NE(input_error_of([&] { read_pose(written("none.json", "{}")); }).find("no field 'T_base_part'"),
            std::string::npos);
}

TEST(PlanFile, WhatIsWrittenIsReadBack) {
  const RobotModel robot = load_cell_robot(CellSpec::load(test::repo("scenes/cells/default.yaml")));
  const PartSpec part = PartSpec::load(test::repo("scenes/parts/tube_on_plate.yaml"));
  std::mt19937_64 rng(11);
  WeldPlan plan;
  for (int k = 0; k < 50; ++k) {
    PlanSample s;
    s.t_s = 0.005 * k;
    s.q = test::random_q(robot, rng);
    s.T_base_tcp = random_pose(rng);
    s.seam = k < 10 ? -1 : (k - 10) / 10;
    s.arc = s.seam >= 0;
    s.phase = s.arc ? Phase::kWeld : Phase::kApproach;
    plan.samples.push_back(s);
  }
  const std::string path = temp_path("plan.json");
  write_json_file(path, plan_to_json(plan, part, robot, PlanSetting()), -1);
  const WeldPlan back = read_plan(path);
  ASSERT_EQ(back.samples.size(), plan.samples.size());
  for (size_t k = 0; k < plan.samples.size(); ++k) {
    const PlanSample &a = plan.samples[k], &b = back.samples[k];
    EXPECT_EQ(a.t_s, b.t_s);
    EXPECT_LT((a.q - b.q).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((a.T_base_tcp.matrix() - b.T_base_tcp.matrix()).cwiseAbs().maxCoeff(), 1e-9) << k;
    EXPECT_EQ(a.seam, b.seam);
    EXPECT_EQ(a.arc, b.arc);
  }
  // The CSV: a header, then one line per sample with t and the six joints.
  std::istringstream csv(plan_to_csv(plan));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "t,j1,j2,j3,j4,j5,j6");
  for (const PlanSample& s : plan.samples) {
    ASSERT_TRUE(std::getline(csv, line));
    double v[7];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4],
                          &v[5], &v[6]),
              7);
    EXPECT_NEAR(v[0], s.t_s, 1e-4);
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(v[j + 1], s.q[j], 1e-9);
  }
  EXPECT_FALSE(std::getline(csv, line));
  // The tube on its plate has four seams and the plan welds each; the round tube has one, and the plan names
  // seams it does not have.
  EXPECT_EQ(input_error_of([&] { check_plan_for_part(back, part, path); }), "");
  const PartSpec round = PartSpec::load(test::repo("scenes/parts/round_on_plate.yaml"));
  EXPECT_NE(input_error_of([&] { check_plan_for_part(back, round, path); }).find("names seam"),
            std::string::npos);
}

TEST(MountFile, WhatIsWrittenIsReadBack) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> mm(-10.0, 10.0), deg(-30.0, 30.0);
  for (int k = 0; k < 50; ++k) {
    const Iso3 correction = mount_offset({mm(rng), mm(rng), mm(rng)}, {deg(rng), deg(rng), deg(rng)});
    write_json_file(temp_path("mount.json"), mount_correction_json({"lidar", correction}));
    const MountCorrection back = read_mount_file(temp_path("mount.json"));
    EXPECT_EQ(back.lidar_link, "lidar");
    EXPECT_LT((back.correction.matrix() - correction.matrix()).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
  // Roll, pitch, yaw as URDF reads them: R = Rz(yaw) Ry(pitch) Rx(roll).
  const Vec3 rpy = rpy_deg(mount_offset({}, {5.0, -3.0, 40.0}).linear());
  EXPECT_NEAR(rpy.x(), 5.0, 1e-9);
  EXPECT_NEAR(rpy.y(), -3.0, 1e-9);
  EXPECT_NEAR(rpy.z(), 40.0, 1e-9);
}

TEST(MountFile, WhatIsNotAMountIsRefused) {
  for (const char* text :
       {R"({})", R"({"lidar_link": "lidar", "correction": {"xyz_m": [0, 0], "rpy_deg": [0, 0, 0]}})",
        R"({"lidar_link": "", "correction": {"xyz_m": [0, 0, 0], "rpy_deg": [0, 0, 0]}})",
        R"({"lidar_link": "lidar", "correction": {"xyz_m": [0, 0, null], "rpy_deg": [0, 0, 0]}})",
        R"({"lidar_link": 3, "correction": {"xyz_m": [0, 0, 0], "rpy_deg": [0, 0, 0]}})"}) {
    const std::string path = written("bad_mount.json", text);
    const std::string why = input_error_of([&] { read_mount_file(path); });
    EXPECT_NE(why.find("bad_mount.json"), std::string::npos) << text << ": " << why;
    EXPECT_NE(why.find("not a mount JSON"), std::string::npos) << text << ": " << why;
  }
  EXPECT_NE(input_error_of([&] { read_mount_file(temp_path("absent.json")); }).find("cannot open"),
            std::string::npos);
}

TEST(JsonFile, AFileThatCannotBeWrittenIsNamed) {
  const std::string path = "/nonexistent_dir_of_weldtwin/out.json";
  for (const std::string& why : {input_error_of([&] { write_json_file(path, nlohmann::json::object()); }),
                                 input_error_of([&] { write_text_file(path, "<html></html>"); })}) {
    EXPECT_NE(why.find(path), std::string::npos) << why;
    EXPECT_NE(why.find("cannot be written"), std::string::npos) << why;
  }
  // A device that refuses every byte: the write is found short when the file is closed.
  if (std::filesystem::exists("/dev/full")) {
    const std::string full = input_error_of([&] { write_text_file("/dev/full", std::string(1 << 16, 'x')); });
    EXPECT_NE(full.find("could not be written whole"), std::string::npos) << full;
  }
  // What is written is all there.
  const std::string text(100000, 'w');
  write_text_file(temp_path("text.html"), text);
  std::ifstream in(temp_path("text.html"), std::ios::binary);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), text);
}

}  // namespace
}  // namespace weldtwin
