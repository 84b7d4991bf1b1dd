// The command line as a user meets it: --help, and bad input ending in one clear line and exit code 2.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "app/mount_file.hpp"
#include "core/cell_robot.hpp"
#include "core/cloud_io.hpp"
#include "tests/real_data.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

struct CliRun {
  int code;
  std::string err;
};

CliRun weldtwin(const std::string& args) {
  const std::string err_file = (std::filesystem::temp_directory_path() / "weldtwin_cli_test.err").string();
  const std::string cmd = std::string(WELDTWIN_BINARY) + " " + args + " >/dev/null 2>" + err_file;
  const int status = std::system(cmd.c_str());
  std::ifstream in(err_file);
  std::string err((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return {WEXITSTATUS(status), err};
}

std::string temp_file(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_test";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string cell_with(const std::string& extra_part, const std::string& robot = "") {
  return "environment: " + test::repo("scenes/cells/default.xml") +
         "\nrobot: " + (robot.empty() ? test::repo("scenes/robots/aubo_i5.urdf") : robot) +
         "\nsweep: " + test::repo("scenes/sweeps/default.yaml") +
         "\npart:\n  spec: " + test::repo("scenes/parts/tube_on_plate.yaml") + "\n" + extra_part;
}

void expect_bad_input(const CliRun& r, const std::string& must_mention) {
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find(must_mention), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "not one line: " << r.err;
}

TEST(Cli, HelpExplainsTheScanCommand) {
  const std::string out = (std::filesystem::temp_directory_path() / "weldtwin_help.txt").string();
  ASSERT_EQ(std::system((std::string(WELDTWIN_BINARY) + " scan --help >" + out).c_str()), 0);
  std::ifstream in(out);
  const std::string help((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* word : {"--seed", "--out", "--cloud", "--truth", "ScanLog"})
    EXPECT_NE(help.find(word), std::string::npos) << word;
}

TEST(Cli, BadInputGivesOneLineAndExitCode2) {
  const std::string out = (std::filesystem::temp_directory_path() / "weldtwin_cli.scanlog").string();
  expect_bad_input(weldtwin("scan /nonexistent/cell.yaml --out " + out), "cell.yaml");
  const std::string malformed = temp_file("malformed.yaml", "name: [oops\n");
  expect_bad_input(weldtwin("scan " + malformed + " --out " + out), "malformed.yaml");
  const std::string far = temp_file("far.yaml", cell_with("  x_m: 0.64\n  y_m: 0.0\n"));
  expect_bad_input(weldtwin("scan " + far + " --out " + out), "out of reach");
  const std::string sunk = temp_file("sunk.yaml", cell_with("  x_m: 0.44\n  y_m: 0.0\n  z_mm: -3\n"));
  expect_bad_input(weldtwin("scan " + sunk + " --out " + out), "intersects the table");
  const std::string urdf = temp_file("broken.urdf", "<robot name='r'><link name='a'></robot>");
  const std::string bad_robot = temp_file("badrobot.yaml", cell_with("  x_m: 0.44\n  y_m: 0.0\n", urdf));
  expect_bad_input(weldtwin("scan " + bad_robot + " --out " + out), "broken.urdf");
  const std::string part = temp_file("nomesh_part.yaml", "name: p\nmodel: missing_mesh.stl\n");
  std::string nomesh = cell_with("  x_m: 0.44\n  y_m: 0.0\n");
  nomesh.replace(nomesh.find(test::repo("scenes/parts/tube_on_plate.yaml")),
                 test::repo("scenes/parts/tube_on_plate.yaml").size(), part);
  expect_bad_input(weldtwin("scan " + temp_file("nomesh.yaml", nomesh) + " --out " + out),
                   "missing_mesh.stl");
}

TEST(Cli, RunSaysWhereToPutAPartThatDoesNotWeldWhereItLies) {
  // The default cell's seed 11 with the straight torch: the upper arm meets the table on seam 'back'.
  const std::string cell = temp_file(
      "straight.yaml", cell_with("clamps: [0, 2]\n", test::repo("scenes/robots/aubo_i5_cell.yaml")));
  const std::string dir = (std::filesystem::temp_directory_path() / "weldtwin_cli_guidance").string();
  const CliRun r = weldtwin("run " + cell + " --seed 11 --out " + dir + " -q");
  EXPECT_EQ(r.code, 3) << r.err;
  std::ifstream in(dir + "/report.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_TRUE(j.contains("placement_suggestion")) << j.dump(1).substr(0, 2000);
  const nlohmann::json& g = j["placement_suggestion"];
  ASSERT_TRUE(g["found"].get<bool>()) << g.dump();
  EXPECT_NE(g["instruction"].get<std::string>().find("the part"), std::string::npos);
  EXPECT_GE(g["planned_and_replayed"].get<int>(), 1);
  EXPECT_GT(g["move_mm"].get<double>() + std::abs(g["turn_deg"].get<double>()), 0.0);
  EXPECT_GT(j["weldability_map"]["welds"].get<int>(), 0);
  EXPECT_TRUE(std::filesystem::exists(dir + "/weldability.png"));
  std::ifstream page(dir + "/report.html");
  const std::string html((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  EXPECT_NE(html.find("Where to put the part"), std::string::npos);
  EXPECT_NE(html.find(g["instruction"].get<std::string>()), std::string::npos);
}

TEST(Cli, ReachMapsThePartOnTheTable) {
  const std::string dir = (std::filesystem::temp_directory_path() / "weldtwin_cli_reach").string();
  const CliRun r = weldtwin("reach " + test::repo("scenes/parts/tube_on_plate.yaml") +
                            " --grid-mm 100 --yaw-step-deg 90 --out " + dir + " -q");
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(dir + "/map.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& n = j["counts"];
  // Every placement of the grid is counted once, and those with room are listed.
  EXPECT_EQ(n["welds"].get<size_t>() + n["out_of_reach"].get<size_t>() + n["collides"].get<size_t>() +
                n["no_room"].get<size_t>(),
            9u * 13u * 4u);
  EXPECT_EQ(j["placements"].size(), 9u * 13u * 4u - n["no_room"].get<size_t>());
  EXPECT_GT(n["welds"].get<size_t>(), 0u);
  EXPECT_TRUE(std::filesystem::exists(dir + "/map.png"));
  expect_bad_input(
      weldtwin("reach " + test::repo("scenes/parts/tube_on_plate.yaml") + " --grid-mm 0 --out " + dir),
      "--grid-mm");
}

TEST(Cli, PlanRefusesBadInputAndUnreachableSeams) {
  const std::string out = (std::filesystem::temp_directory_path() / "weldtwin_cli_plan.json").string();
  const std::string part = test::repo("scenes/parts/tube_on_plate.yaml");
  auto pose = [](double x, double y) {
    return "{\"T_base_part\": [[1,0,0," + std::to_string(x) + "],[0,1,0," + std::to_string(y) +
           "],[0,0,1,0],[0,0,0,1]]}";
  };
  // A good pose plans (exit 0) and writes the plan.
  const CliRun good = weldtwin("plan --part " + part + " --pose " + temp_file("good.json", pose(0.46, 0.0)) +
                               " --out " + out + " --csv " + out + ".csv -q");
  EXPECT_EQ(good.code, 0) << good.err;
  EXPECT_GT(std::filesystem::file_size(out + ".csv"), 10000u);
  // With a cell, the plan avoids the cell's table, clamps and clutter, and says so (examples/03 replays one);
  // at the cell's own placement of the part.
  const CliRun in_cell =
      weldtwin("plan --part " + part + " --pose " + temp_file("cell.json", pose(0.48, 0.06)) + " --cell " +
               test::repo("scenes/cells/default.yaml") + " --out " + out + " -q");
  EXPECT_EQ(in_cell.code, 0) << in_cell.err;
  {
    std::ifstream in(out);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("\"collisions_checked\":true"), std::string::npos);
  }
  // Out of reach: the job ran, the answer is "cannot weld": exit 3, the seam named, the plan says why.
  const CliRun far = weldtwin("plan --part " + part + " --pose " + temp_file("far.json", pose(1.10, 0.0)) +
                              " --out " + out + " -q");
  EXPECT_EQ(far.code, 3) << far.err;
  EXPECT_NE(far.err.find("seam 'front'"), std::string::npos) << far.err;
  std::ifstream in(out);
  const std::string plan((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(plan.find("\"ok\":false"), std::string::npos);
  EXPECT_NE(plan.find("unreachable"), std::string::npos);
  // The plan command checks no collisions and says so in the file (the replay in the cell checks them).
  EXPECT_NE(plan.find("\"collisions_checked\":false"), std::string::npos);
  // A pose that puts the part 0.5 m into the table is no pose of it.
  expect_bad_input(
      weldtwin("plan --part " + part + " --pose " +
               temp_file("under.json", "{\"T_base_part\": [[1,0,0,0.46],[0,1,0,0],[0,0,1,-0.5],[0,0,0,1]]}") +
               " --out " + out),
      "500 mm below the table top");
  // A pose that says the part was not found is not planned.
  expect_bad_input(weldtwin("plan --part " + part + " --pose " +
                            temp_file("not_found.json", "{\"found\": false, \"reason\": \"ambiguous\", " +
                                                            pose(0.46, 0.0).substr(1)) +
                            " --out " + out),
                   "the pose says the part was not found (ambiguous)");
  // Bad input: exit 2, one line naming the file.
  expect_bad_input(weldtwin("plan --part " + part + " --pose " +
                            temp_file("broken.json", "{\"T_base_part\": [[1,0") + " --out " + out),
                   "broken.json");
  expect_bad_input(
      weldtwin("plan --part " + part + " --pose " +
               temp_file("skew.json", "{\"T_base_part\": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}") +
               " --out " + out),
      "rigid");
  const std::string stl = test::repo("scenes/parts/tube_on_plate.stl");
  const std::string head = "name: p\nmodel: " + stl + "\nfootprint_m: [[0,0],[1,0],[0,1]]\nseams:\n";
  const std::string tail =
      "    normal: [0, 0, 1]\n    wall_normal: [0, -1, 0]\n    work_angle_deg: 45\n"
      "    travel_angle_deg: 10\n    torch_roll_deg: free\n    speed_mm_s: 8\n";
  const std::string good_pose = temp_file("good2.json", pose(0.46, 0.0));
  expect_bad_input(weldtwin("plan --part " +
                            temp_file("zero_seam.yaml",
                                      head + "  - name: z\n    start: [0,0,0]\n    end: [0,0,0]\n" + tail) +
                            " --pose " + good_pose + " --out " + out),
                   "zero-length");
  expect_bad_input(
      weldtwin("plan --part " +
               temp_file("parallel_seam.yaml",
                         head + "  - name: up\n    start: [0,0,0]\n    end: [0,0,0.05]\n" + tail) +
               " --pose " + good_pose + " --out " + out),
      "parallel");
  expect_bad_input(weldtwin("plan --part " + temp_file("bad_part.yaml", "seams: [oops\n") + " --pose " +
                            good_pose + " --out " + out),
                   "bad_part.yaml");
}

TEST(Cli, ScanWritesLogCloudAndTruth) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_scan";
  std::filesystem::create_directories(dir);
  const CliRun r = weldtwin("scan " + test::repo("scenes/cells/tube_tee.yaml") + " --seed 5 --out " +
                            (dir / "s.scanlog").string() + " --cloud " + (dir / "s.pcd").string() +
                            " --truth " + (dir / "t.json").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("sweeping"), std::string::npos);  // progress lines
  EXPECT_GT(std::filesystem::file_size(dir / "s.scanlog"), 1000000u);
  EXPECT_GT(std::filesystem::file_size(dir / "s.pcd"), 100000u);
  std::ifstream in(dir / "t.json");
  const std::string truth((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* key : {"T_base_part", "T_base_clamp", "point_labels_rle", "seam_coverage", "\"seed\": 5"})
    EXPECT_NE(truth.find(key), std::string::npos) << key;
  // The cloud says where the LiDAR was for every point (PCL's PointWithViewpoint), and localize uses it.
  std::ifstream pcd(dir / "s.pcd");
  std::string line;
  while (std::getline(pcd, line) && line.rfind("FIELDS", 0) != 0) {
  }
  EXPECT_EQ(line, "FIELDS x y z vp_x vp_y vp_z");
  const CliRun loc = weldtwin("localize --model " + test::repo("scenes/parts/tube_tee.stl") + " --scan " +
                              (dir / "s.pcd").string() + " --out " + (dir / "pose.json").string());
  EXPECT_EQ(loc.code, 0) << loc.err;
  std::ifstream pose(dir / "pose.json");
  const std::string pose_text((std::istreambuf_iterator<char>(pose)), std::istreambuf_iterator<char>());
  EXPECT_NE(pose_text.find("\"rays_cast\": true"), std::string::npos) << pose_text;
  // The part spec alone names the mesh: the same pose as the mesh and the spec given apart.
  const std::string spec = test::repo("scenes/parts/tube_tee.yaml"), scan = (dir / "s.pcd").string();
  ASSERT_EQ(
      weldtwin("localize -q --part " + spec + " --scan " + scan + " --out " + (dir / "a.json").string()).code,
      0);
  ASSERT_EQ(weldtwin("localize -q --part " + spec + " --model " + test::repo("scenes/parts/tube_tee.stl") +
                     " --scan " + scan + " --out " + (dir / "b.json").string())
                .code,
            0);
  nlohmann::json a, b;
  std::ifstream(dir / "a.json") >> a;
  std::ifstream(dir / "b.json") >> b;
  EXPECT_TRUE(a["found"].get<bool>());
  EXPECT_EQ(a["T_base_part"], b["T_base_part"]);
  // The cell's table top given: where the twin has it (z = 0), found the same; given 3 mm higher than the
  // scan shows it, refused as a mount that is off.
  const std::string with_table = "localize -q --part " + spec + " --scan " + scan + " --table-top-z-mm ";
  ASSERT_EQ(weldtwin(with_table + "0 --out " + (dir / "d.json").string()).code, 0);
  nlohmann::json d, e;
  std::ifstream(dir / "d.json") >> d;
  EXPECT_EQ(a["T_base_part"], d["T_base_part"]);
  EXPECT_EQ(weldtwin(with_table + "3 --out " + (dir / "e.json").string()).code, 3);
  std::ifstream(dir / "e.json") >> e;
  EXPECT_FALSE(e["found"].get<bool>());
  EXPECT_EQ(e["reason"].get<std::string>().rfind("the table is seen 3.0 mm below where the cell has it", 0),
            0u)
      << e["reason"];
  expect_bad_input(weldtwin("localize --scan " + scan + " --out " + (dir / "c.json").string()),
                   "--part SPEC");
}

TEST(Cli, LocalizeKeepsThePreparedPartForTheNextRunAndAnswersTheSame) {
  // A twin scan localized three times with a folder for kept parts: the first run prepares the part and
  // keeps it, the next ones read it (and its lookups), and all give the pose of a run that keeps nothing.
  // --no-part-cache and WELDTWIN_PART_CACHE=off keep nothing.
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_part_cache";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const test::TwinScan twin = test::twin_scan("scenes/cells/default.yaml", 6);
  const std::string scan = (dir / "scan.pcd").string(), kept = (dir / "kept").string();
  write_pcd(scan, twin.cloud, false, &twin.viewpoints);
  const std::string base = "localize -q --part " + test::repo("scenes/parts/tube_on_plate.yaml") +
                           " --scan " + scan + " --out " + dir.string() + "/";
  auto pose = [&](const std::string& name) {
    nlohmann::json j;
    std::ifstream(dir / name) >> j;
    return j;
  };
  ASSERT_EQ(weldtwin(base + "off.json --no-part-cache --part-cache " + kept).code, 0);
  EXPECT_FALSE(std::filesystem::exists(kept));
  for (const char* run : {"1.json", "2.json", "3.json"})
    ASSERT_EQ(weldtwin(base + run + " --part-cache " + kept).code, 0) << run;
  EXPECT_EQ(pose("off.json")["part_cache"], "off");
  EXPECT_EQ(pose("1.json")["part_cache"], "written");
  EXPECT_EQ(pose("2.json")["part_cache"], "read");
  EXPECT_EQ(pose("3.json")["part_cache"], "read");
  for (const char* run : {"1.json", "2.json", "3.json"}) {
    EXPECT_EQ(pose(run)["T_base_part"], pose("off.json")["T_base_part"]) << run;
    EXPECT_EQ(pose(run)["seam_error_bound_mm"], pose("off.json")["seam_error_bound_mm"]) << run;
  }
  size_t parts = 0, lookups = 0;
  for (const auto& e : std::filesystem::directory_iterator(kept)) {
    parts += e.path().extension() == ".part";
    lookups += e.path().extension() == ".lookup";
  }
  EXPECT_EQ(parts, 1u);
  EXPECT_EQ(lookups, 1u);
  const std::string off =
      "WELDTWIN_PART_CACHE=off " + std::string(WELDTWIN_BINARY) + " " + base + "env_off.json >/dev/null 2>&1";
  ASSERT_EQ(std::system(off.c_str()), 0);
  EXPECT_EQ(pose("env_off.json")["part_cache"], "off");
}

// Clouds from another tool that are no table scene in a robot's base frame (PCL's own test clouds, where the
// real-data folder is present): read, and refused as untrustworthy (exit 3) with the reason, never a pose.
TEST(Cli, OtherToolsCloudsOfNoTableSceneAreRefusedWithTheReason) {
  const std::string clouds = test::real_data("clouds");
  if (!std::filesystem::exists(clouds + "/bun0.pcd")) GTEST_SKIP() << "skipped: " << clouds << " not found";
  const auto out = std::filesystem::temp_directory_path() / "weldtwin_cli_clouds.json";
  for (const char* name : {"bun0.pcd", "bun4.pcd", "milk_color.pcd", "noisy_slice_displaced.pcd",
                           "sac_plane_test.pcd", "table_scene_mug_stereo_textured.pcd", "cube.ply"}) {
    const CliRun r = weldtwin("localize -q --part " + test::repo("scenes/parts/tube_on_plate.yaml") +
                              " --scan " + clouds + "/" + name + " --out " + out.string());
    EXPECT_EQ(r.code, 3) << name << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(name) +
                         ": part not found: no table plane in the scan: no plane within 15 deg"),
              std::string::npos)
        << r.err;
    nlohmann::json pose;
    std::ifstream(out) >> pose;
    EXPECT_FALSE(pose["found"].get<bool>()) << name;
  }
}

TEST(Cli, ReplayJudgesAPlanInTheCellItWasMadeForAndNotElsewhere) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_replay";
  std::filesystem::remove_all(dir);
  // The default job leaves its plan; replayed in the same cell it passes, in another layout of the cell
  // (the part elsewhere, clamps elsewhere) it must fail, with the reason in the report.
  ASSERT_EQ(weldtwin("run --no-renders -q --out " + (dir / "run").string()).code, 0);
  const std::string plan = (dir / "run" / "plan.json").string();
  EXPECT_EQ(weldtwin("replay " + plan + " --no-renders -q --out " + (dir / "same").string()).code, 0);
  const CliRun other = weldtwin("replay " + plan + " " + test::repo("scenes/cells/default.yaml") +
                                " --seed 3 --no-renders -q --out " + (dir / "other").string());
  EXPECT_EQ(other.code, 3);
  // -q silences progress, not the verdict: one line on stderr naming the plan.
  EXPECT_NE(other.err.find("weldtwin: " + plan + ": replay: "), std::string::npos) << other.err;
  std::ifstream in(dir / "other" / "report.json");
  const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(report.find("\"verdict\": \"FAIL\""), std::string::npos);
  // A plan that is not one.
  expect_bad_input(weldtwin("replay " + temp_file("empty_plan.json", "{\"samples\": []}")), "no samples");
  expect_bad_input(
      weldtwin("replay " + temp_file("bad_plan.json", "{\"samples\": [{\"t\": 0, \"q\": [1, 2]}]}")), "q[6]");
  // The real plan mutated as a hostile file would (these had crashed the replay with free(), run it for 1e7
  // s, or passed it "within 0.000 mm" with nothing welded): each refused naming what is wrong.
  nlohmann::json good;
  std::ifstream(plan) >> good;
  auto mutated = [&](const std::string& name, const std::function<void(nlohmann::json&)>& change) {
    nlohmann::json j = good;
    change(j);
    return temp_file(name, j.dump());
  };
  auto& samples = good["samples"];
  ASSERT_GT(samples.size(), 100u);
  expect_bad_input(
      weldtwin("replay " + mutated("seam99.json", [](nlohmann::json& j) { j["samples"][10]["seam"] = 99; })),
      "names seam 99");
  expect_bad_input(
      weldtwin("replay " + mutated("late.json", [](nlohmann::json& j) { j["samples"].back()["t"] = 1e7; })),
      "s after the one before");
  expect_bad_input(weldtwin("replay " + mutated("cold.json",
                                                [](nlohmann::json& j) {
                                                  for (auto& x : j["samples"]) x["arc"] = false;
                                                })),
                   "does not weld seam");
  expect_bad_input(weldtwin("replay " + mutated("half.json",
                                                [](nlohmann::json& j) {
                                                  for (auto& x : j["samples"])
                                                    if (x.value("seam", -1) >= 2)
                                                      x["seam"] = -1, x["arc"] = false;
                                                })),
                   "does not weld seam");
  expect_bad_input(
      weldtwin("replay " + mutated("arc1.json", [](nlohmann::json& j) { j["samples"][5]["arc"] = 1; })),
      "arc must be true or false");
}

// The switch on the command line: a sweep recorded by `weldtwin scan` as a ROS 1 and a ROS 2 bag, run through
// `--source log:`, finds the part where the live twin run finds it and gives the same verdict; a live LiDAR
// source that is not there is refused with one line.
TEST(Cli, RunFromRecordedBagsMatchesTheLiveRun) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_source";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string cell = test::repo("scenes/cells/default.yaml");
  ASSERT_EQ(weldtwin("scan " + cell + " -q --out " + (dir / "s.scanlog").string() + " --rosbag " +
                     (dir / "s.bag").string() + " --rosbag2 " + (dir / "s_ros2").string())
                .code,
            0);
  const CliRun live = weldtwin("run " + cell + " --no-renders -q --out " + (dir / "live").string());
  ASSERT_TRUE(live.code == 0 || live.code == 3) << live.err;
  auto pose_of = [](const std::filesystem::path& run) {
    std::ifstream in(run / "pose.json");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return text.substr(text.find("\"T_base_part\""), 400);
  };
  for (const char* log : {"s.bag", "s_ros2"}) {
    const CliRun r = weldtwin("run " + cell + " --no-renders -q --source log:" + (dir / log).string() +
                              " --out " + (dir / (std::string("from_") + log)).string());
    EXPECT_EQ(r.code, live.code) << log << ": " << r.err;
    EXPECT_EQ(pose_of(dir / (std::string("from_") + log)), pose_of(dir / "live")) << log;
  }
  expect_bad_input(weldtwin("run --no-renders -q --source lidar:/dev/ttyUSB7 --out " + (dir / "x").string()),
                   "a live sweep moves the arm: add --execute");
  expect_bad_input(
      weldtwin("run --no-renders -q --execute --source lidar:/dev/ttyUSB7 --out " + (dir / "x").string()),
      "/dev/ttyUSB7: cannot open the RPLIDAR's port");
  expect_bad_input(weldtwin("run --no-renders -q --source log:" + (dir / "nothing.bag").string() + " --out " +
                            (dir / "x").string()),
                   "nothing.bag");
}

// `weldtwin calibrate` in the twin: a mount put wrong is found again and said so; a cell without the box is
// refused.
TEST(Cli, CalibrateFindsAWrongMountInTheTwin) {
  const std::string out = temp_file("mount.json", "");
  const std::string urdf = temp_file("calibrated.urdf", "");
  const CliRun r = weldtwin("calibrate -q --mount-error-mm -1 2 0.5 --mount-error-deg 0.3 0.2 -0.4 --out " +
                            out + " --urdf-out " + urdf);
  ASSERT_EQ(r.code, 0) << r.err;
  // The URDF written with the calibrated mount puts the LiDAR where the twin's wrong mount really had it, and
  // changes nothing else; written elsewhere, it still finds the vendor's meshes.
  const RobotModel nominal = load_cell_robot(CellSpec::load(test::repo("scenes/cells/calibration.yaml")));
  const RobotModel calibrated = RobotModel::load(urdf);
  const int upper_arm = calibrated.require_link("upperArm_Link");
  ASSERT_EQ(calibrated.links()[static_cast<size_t>(upper_arm)].collision_meshes.size(), 1u);
  const RobotModel real = nominal.with_mount_offset("lidar", mount_offset({-1, 2, 0.5}, {0.3, 0.2, -0.4}));
  std::mt19937_64 rng(5);
  for (int k = 0; k < 20; ++k) {
    const JointVector q = test::random_q(nominal, rng);
    const Iso3 a = calibrated.forward_kinematics(q, calibrated.require_link("lidar"));
    const Iso3 b = real.forward_kinematics(q, real.require_link("lidar"));
    EXPECT_LT((a.translation() - b.translation()).norm(), 5e-4);
    EXPECT_LT(rad2deg(Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle()), 0.1);
    const Iso3 f = calibrated.forward_kinematics(q, calibrated.require_link("flange"));
    EXPECT_LT((f.matrix() - nominal.forward_kinematics(q, nominal.require_link("flange")).matrix()).norm(),
              1e-12);
  }
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find("\"translation_error_mm\"");
  ASSERT_NE(at, std::string::npos) << text;
  EXPECT_LT(std::stod(text.substr(text.find(':', at) + 1)), 0.5);
  const size_t rot = text.find("\"rotation_error_deg\"");
  EXPECT_LT(std::stod(text.substr(text.find(':', rot) + 1)), 0.1);
  expect_bad_input(weldtwin("calibrate " + test::repo("scenes/cells/default.yaml") + " -q --out " + out),
                   "is the calibration box on the table?");
  // End to end: the default job in a cell whose LiDAR mount is that far off misses the seams; with the
  // calibrated mount it welds them.
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_cli_calibrated";
  const std::string wrong =
      " --mount-error-mm -1 2 0.5 --mount-error-deg 0.3 0.2 -0.4 --no-renders -q --out ";
  EXPECT_EQ(weldtwin("run" + wrong + (dir / "uncalibrated").string()).code, 3);
  const CliRun calibrated_run =
      weldtwin("run" + wrong + (dir / "calibrated").string() + " --lidar-mount " + out);
  EXPECT_EQ(calibrated_run.code, 0) << calibrated_run.err;
  expect_bad_input(weldtwin("run --no-renders -q --lidar-mount " + temp_file("bad_mount.json", "{}") +
                            " --out " + (dir / "x").string()),
                   "not a mount JSON");
}

}  // namespace
}  // namespace weldtwin
