// The command line as a user meets it: --help, and bad input ending in one clear line and exit code 2.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

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
  const std::string part = temp_file("nomesh_part.yaml", "name: p\nmodel: missing_mesh.stl\nheight_m: 0.1\n");
  std::string nomesh = cell_with("  x_m: 0.44\n  y_m: 0.0\n");
  nomesh.replace(nomesh.find(test::repo("scenes/parts/tube_on_plate.yaml")),
                 test::repo("scenes/parts/tube_on_plate.yaml").size(), part);
  expect_bad_input(weldtwin("scan " + temp_file("nomesh.yaml", nomesh) + " --out " + out),
                   "missing_mesh.stl");
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
}

}  // namespace
}  // namespace weldtwin
