// Part and cell specs: the shipped scenes load, and malformed ones fail with the file and field named.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "tests/input_error_of.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

std::string write_temp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_specs_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

using test::input_error_of;

TEST(PartSpec, ShippedPartsLoadWithTheirSeams) {
  const PartSpec tube = PartSpec::load(test::repo("scenes/parts/tube_on_plate.yaml"));
  ASSERT_EQ(tube.seams.size(), 4u);
  for (const Seam& s : tube.seams) {
    EXPECT_NEAR(s.length_m(), 0.0508, 1e-9);
    // The seam lies at the tube's foot, on the plate's top face.
    EXPECT_NEAR(s.start.z(), 0.008, 1e-12);
    EXPECT_NEAR(s.normal.dot(s.wall_normal), 0.0, 1e-12);
    EXPECT_NEAR(s.work_angle_rad, deg2rad(45), 1e-12);
    EXPECT_FALSE(s.torch_roll_rad.has_value());
    EXPECT_NEAR(s.speed_m_s, 0.008, 1e-12);
  }
  const PartSpec round = PartSpec::load(test::repo("scenes/parts/round_on_plate.yaml"));
  ASSERT_EQ(round.seams.size(), 1u);
  const Seam& foot = round.seams[0];
  EXPECT_EQ(foot.kind, Seam::Kind::kArc);
  EXPECT_NEAR(foot.length_m(), 2 * kPi * 0.03015, 1e-9);
  // Every point of the circle is at the tube radius, and m points radially outwards.
  for (double f : {0.0, 0.3, 0.77}) {
    EXPECT_NEAR((foot.point_at(f) - foot.center).norm(), 0.03015, 1e-12);
    EXPECT_NEAR(foot.wall_normal_at(f).dot((foot.point_at(f) - foot.center).normalized()), 1.0, 1e-12);
    EXPECT_NEAR(foot.direction_at(f).dot(foot.wall_normal_at(f)), 0.0, 1e-12);
  }
  const PartSpec tee = PartSpec::load(test::repo("scenes/parts/tube_tee.yaml"));
  EXPECT_EQ(tee.seams.size(), 3u);
  EXPECT_GE(tee.clamp_sites.size(), 2u);
}

TEST(PartSpec, BadSpecsAreRejected) {
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  const std::string head = "name: p\nmodel: " + stl + "\nfootprint_m: [[0,0],[1,0],[0,1]]\n";
  const std::string seam = "seams:\n  - name: s\n    start: [0, 0, 0]\n";
  const std::string tail =
      "    normal: [0, 0, 1]\n    wall_normal: [0, -1, 0]\n    work_angle_deg: 45\n"
      "    travel_angle_deg: 0\n    torch_roll_deg: free\n    speed_mm_s: 8\n";
  EXPECT_NE(input_error_of([&] {
              PartSpec::load(write_temp("zero.yaml", head + seam + "    end: [0, 0, 0]\n" + tail));
            }).find("zero-length"),
            std::string::npos);
  const std::string parallel = head + seam + "    end: [0, 0, 0.05]\n" + tail;  // travel along n
  EXPECT_NE(input_error_of([&] { PartSpec::load(write_temp("parallel.yaml", parallel)); }).find("parallel"),
            std::string::npos);
  EXPECT_NE(
      input_error_of([&] { PartSpec::load(write_temp("bad.yaml", "name: [unclosed\n")); }).find("bad.yaml"),
      std::string::npos);
  EXPECT_NE(input_error_of([&] { PartSpec::load(write_temp("empty.yaml", "")); }).find("empty"),
            std::string::npos);
  const std::string missing_mesh = "name: p\nmodel: nowhere.stl\n";
  EXPECT_NE(
      input_error_of([&] { PartSpec::load(write_temp("nomesh.yaml", missing_mesh)); }).find("nowhere.stl"),
      std::string::npos);
  // A model path too long for the file system (the fuzzer's): "does not exist", not a filesystem_error.
  const std::string long_path = "name: p\nmodel: " + std::string(5000, 'a') + ".stl\n";
  EXPECT_NE(
      input_error_of([&] { PartSpec::load(write_temp("longpath.yaml", long_path)); }).find("does not exist"),
      std::string::npos);
  const std::string letters = head + seam + "    end: [0, x, 0]\n" + tail;
  EXPECT_NE(input_error_of([&] { PartSpec::load(write_temp("letters.yaml", letters)); }).find("letters.yaml"),
            std::string::npos);
}

// What mutated specs had been planned as "ok": a seam too slow to have weld samples (or eating all memory at
// 0.001 mm/s), a torch pointing into the part (work angle 180 deg), a normal of 1e308 that normalised to
// zero (the torch horizontal). Now the first two are refused naming the field, the third is the direction it
// says.
TEST(PartSpec, WeldToleranceIsReadInMillimetresAndKeptWithinWhatAWeldAllows) {
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  const std::string spec = "name: p\nmodel: " + stl +
                           "\nseams:\n  - {name: s, start: [-0.0254, -0.0254, 0.008], end: [0.0254, -0.0254, "
                           "0.008], normal: [0, 0, 1], wall_normal: [0, -1, 0], work_angle_deg: 45, "
                           "travel_angle_deg: 0, torch_roll_deg: free, speed_mm_s: 8}\n";
  EXPECT_DOUBLE_EQ(PartSpec::load(write_temp("tol_default.yaml", spec)).weld_tolerance_m, 1e-3);
  EXPECT_DOUBLE_EQ(
      PartSpec::load(write_temp("tol_half.yaml", spec + "weld_tolerance_mm: 0.5\n")).weld_tolerance_m, 5e-4);
  for (const char* bad : {"0", "-1", "0.05", "12", ".nan", ".inf"}) {
    const std::string file = "tol_bad.yaml";
    const std::string err = input_error_of(
        [&] { PartSpec::load(write_temp(file, spec + "weld_tolerance_mm: " + std::string(bad) + "\n")); });
    EXPECT_NE(err.find("weld_tolerance_mm"), std::string::npos) << bad << ": " << err;
    EXPECT_NE(err.find(file), std::string::npos) << bad << ": " << err;
  }
}

TEST(PartSpec, SeamsNoTorchCanWeldAreRejectedAndHugeDirectionsKept) {
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  auto spec = [&](const std::string& normal, const std::string& work, const std::string& travel,
                  const std::string& speed) {
    return "name: p\nmodel: " + stl +
           "\nfootprint_m: [[0,0],[1,0],[0,1]]\nseams:\n  - name: s\n    start: [0, 0, 0]\n"
           "    end: [0.05, 0, 0]\n    normal: " +
           normal + "\n    wall_normal: [0, -1, 0]\n    work_angle_deg: " + work +
           "\n    travel_angle_deg: " + travel + "\n    torch_roll_deg: free\n    speed_mm_s: " + speed +
           "\n";
  };
  for (const char* speed : {"0.000001", "0.001", "1e308", "-8", "0"})
    EXPECT_NE(input_error_of([&] {
                PartSpec::load(write_temp("speed.yaml", spec("[0, 0, 1]", "45", "10", speed)));
              }).find("speed_mm_s must be within"),
              std::string::npos)
        << speed;
  for (const char* work : {"180", "-10", "91"})
    EXPECT_NE(input_error_of([&] {
                PartSpec::load(write_temp("work.yaml", spec("[0, 0, 1]", work, "10", "8")));
              }).find("work_angle_deg must be within 0-90"),
              std::string::npos)
        << work;
  EXPECT_NE(input_error_of([&] {
              PartSpec::load(write_temp("travel.yaml", spec("[0, 0, 1]", "45", "60", "8")));
            }).find("travel_angle_deg"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] {
              PartSpec::load(write_temp("normal.yaml", spec("[0, 0, 0]", "45", "10", "8")));
            }).find("normal must be a finite, non-zero direction"),
            std::string::npos);
  for (const char* bad : {"[0, 0, .nan]", "[0, .inf, 0]"})
    EXPECT_NE(input_error_of([&] {
                PartSpec::load(write_temp("normal.yaml", spec(bad, "45", "10", "8")));
              }).find("must be finite"),
              std::string::npos)
        << bad;
  const PartSpec huge = PartSpec::load(write_temp("huge.yaml", spec("[0, 0, 1e308]", "45", "10", "8")));
  EXPECT_NEAR((huge.seams[0].normal - Vec3::UnitZ()).norm(), 0.0, 1e-12);
  // 2000 seams (all memory, had been): refused by their number.
  std::string many = spec("[0, 0, 1]", "45", "10", "8");
  const std::string one = many.substr(many.find("  - name: s"));
  for (int i = 0; i < 1999; ++i) many += one;
  EXPECT_NE(input_error_of([&] { PartSpec::load(write_temp("many.yaml", many)); }).find("lists 2000 seams"),
            std::string::npos);
  const PartSpec edge = PartSpec::load(write_temp("edge.yaml", spec("[0, 0, 1]", "90", "-45", "0.5")));
  EXPECT_NEAR(edge.seams[0].work_angle_rad, kPi / 2, 1e-12);
}

// The angle windows a weld accepts: read in degrees, the nominal when left out, refused when the window
// leaves the torch's range or does not hold the nominal.
TEST(PartSpec, SeamAngleWindowsAreReadAndChecked) {
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  auto spec = [&](const std::string& extra) {
    return "name: p\nmodel: " + stl +
           "\nseams:\n  - name: s\n    start: [0, 0, 0]\n    end: [0.05, 0, 0]\n    normal: [0, 0, 1]\n"
           "    wall_normal: [0, -1, 0]\n    work_angle_deg: 45\n    travel_angle_deg: 10\n" +
           extra + "    torch_roll_deg: free\n    speed_mm_s: 8\n";
  };
  const Seam plain = PartSpec::load(write_temp("plain.yaml", spec(""))).seams[0];
  EXPECT_EQ(plain.work_angle_tol_rad, 0.0);
  EXPECT_NEAR(plain.travel_angle_min_rad, deg2rad(10), 1e-12);
  EXPECT_NEAR(plain.travel_angle_max_rad, deg2rad(10), 1e-12);
  const Seam windowed = PartSpec::load(write_temp("window.yaml", spec("    work_angle_tol_deg: 10\n"
                                                                      "    travel_angle_min_deg: -15\n"
                                                                      "    travel_angle_max_deg: 20\n")))
                            .seams[0];
  EXPECT_NEAR(windowed.work_angle_tol_rad, deg2rad(10), 1e-12);
  EXPECT_NEAR(windowed.travel_angle_min_rad, deg2rad(-15), 1e-12);
  EXPECT_NEAR(windowed.travel_angle_max_rad, deg2rad(20), 1e-12);
  for (const char* bad : {"    work_angle_tol_deg: 50\n", "    work_angle_tol_deg: -1\n"})
    EXPECT_NE(input_error_of([&] {
                PartSpec::load(write_temp("bad.yaml", spec(bad)));
              }).find("work_angle_deg +- work_angle_tol_deg must stay within 0-90"),
              std::string::npos)
        << bad;
  for (const char* bad : {"    travel_angle_max_deg: 5\n", "    travel_angle_min_deg: 12\n",
                          "    travel_angle_min_deg: -50\n", "    travel_angle_max_deg: 46\n"})
    EXPECT_NE(input_error_of([&] {
                PartSpec::load(write_temp("bad.yaml", spec(bad)));
              }).find("travel_angle_min_deg <= travel_angle_deg <= travel_angle_max_deg"),
              std::string::npos)
        << bad;
}

TEST(CellSpec, DefaultCellLoadsAndBadOnesAreRejected) {
  const CellSpec cell = CellSpec::load(test::repo("scenes/cells/default.yaml"));
  EXPECT_TRUE(cell.part_pose.has_value());
  EXPECT_EQ(cell.clamp_sites.size(), 2u);
  EXPECT_NEAR(cell.table.x_max_m - cell.table.x_min_m, 0.8, 1e-12);
  EXPECT_NEAR(cell.table.y_max_m - cell.table.y_min_m, 1.2, 1e-12);
  const std::string dir = test::repo("scenes/cells/");
  EXPECT_NE(input_error_of([&] {
              CellSpec::load(write_temp("c1.yaml", "name: x\nenvironment: " + dir + "nope.xml\n"));
            }).find("nope.xml"),
            std::string::npos);
  const std::string ok_head = "environment: " + dir +
                              "default.xml\nrobot: " + test::repo("scenes/robots/aubo_i5.urdf") +
                              "\nsweep: " + test::repo("scenes/sweeps/default.yaml") + "\n";
  EXPECT_NE(input_error_of([&] { CellSpec::load(write_temp("c2.yaml", ok_head)); }).find("part"),
            std::string::npos);
  // A rescan is optional; named, or listed, its files must exist.
  EXPECT_TRUE(cell.rescan_programs.empty());
  const std::string part = "part: {spec: " + test::repo("scenes/parts/tube_tee.yaml") + "}\n";
  const std::string crossing = test::repo("scenes/sweeps/crossing_pass.yaml");
  const std::string outer = test::repo("scenes/sweeps/outer_passes.yaml");
  EXPECT_EQ(
      CellSpec::load(write_temp("c4.yaml", ok_head + part + "rescan: " + crossing + "\n")).rescan_programs,
      std::vector<std::string>{crossing});
  EXPECT_EQ(
      CellSpec::load(write_temp("c6.yaml", ok_head + part + "rescan: [" + crossing + ", " + outer + "]\n"))
          .rescan_programs,
      (std::vector<std::string>{crossing, outer}));
  EXPECT_NE(input_error_of([&] {
              CellSpec::load(write_temp("c5.yaml", ok_head + part + "rescan: " + dir + "nope.yaml\n"));
            }).find("nope.yaml"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] {
              CellSpec::load(write_temp(
                  "c7.yaml", ok_head + part + "rescan: [" + crossing + ", " + dir + "nope.yaml]\n"));
            }).find("nope.yaml"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] {
              CellSpec::load(write_temp("c8.yaml", ok_head + part + "rescan: {a: 1}\n"));
            }).find("rescan"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] {
              CellSpec::load(write_temp(
                  "c3.yaml",
                  ok_head + "part: {spec: " + test::repo("scenes/parts/tube_tee.yaml") + ", x_m: 0.4}\n"));
            }).find("both x and y"),
            std::string::npos);
}

}  // namespace
}  // namespace weldtwin
