// `weldtwin run` on seeded cells of one part (the part is the test's argument): the verdict must agree with
// the figures of its own report — PASS only with the part found, a plan, no contact, the robot clear of the
// part (the replay's threshold) and every arc-on torch position within 1 mm of the true seam; FAIL always
// with a reason.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/replay.hpp"
#include "tests/test_support.hpp"

namespace {

std::string g_cell;

// `cell_file`: a path of its own ("" = the test's cell).
nlohmann::json run_seed(int seed, int& exit_code, const std::string& tag = "",
                        const std::string& cell_file = "") {
  // One directory per cell and seed: the three run tests go side by side (ctest -j), and two processes
  // writing the same scan.pcd (PCL writes it through mmap) end one of them with SIGBUS.
  const std::string path = cell_file.empty() ? weldtwin::test::repo(g_cell) : cell_file;
  const std::string cell = std::filesystem::path(path).stem().string();
  const std::string dir = ::testing::TempDir() + "weldtwin_run_" + cell + tag + "_" + std::to_string(seed);
  std::filesystem::remove_all(dir);  // never a report.json of an earlier run
  const std::string cmd = std::string(WELDTWIN_BINARY) + " run " + path + " --seed " + std::to_string(seed) +
                          " --out " + dir + " --no-renders --no-guidance -q --threads 1 > " + dir +
                          ".stdout 2>&1";
  const int status = std::system(cmd.c_str());
  exit_code = WEXITSTATUS(status);
  std::ifstream in(dir + "/report.json");
  return in ? nlohmann::json::parse(in) : nlohmann::json();
}

TEST(Run, VerdictAgreesWithTheFiguresOnTenSeededCells) {
  int passed = 0;
  for (int seed = 1; seed <= 10; ++seed) {
    int code = -1;
    const nlohmann::json r = run_seed(seed, code);
    ASSERT_TRUE(r.is_object()) << g_cell << " seed " << seed << ": no report.json (exit " << code << ")";
    const bool pass = r["verdict"] == "PASS";
    EXPECT_EQ(code, pass ? 0 : 3) << "seed " << seed;
    if (!pass) {
      EXPECT_FALSE(r["reasons"].empty()) << "seed " << seed << ": FAIL without a reason";
      std::printf("%s seed %d: FAIL: %s\n", g_cell.c_str(), seed, r["reasons"][0].get<std::string>().c_str());
      continue;
    }
    ++passed;
    EXPECT_TRUE(r["reasons"].empty());
    EXPECT_TRUE(r["localization"]["found"].get<bool>());
    EXPECT_TRUE(r["plan"]["ok"].get<bool>());
    const auto& replay = r["replay"];
    EXPECT_TRUE(replay["contacts"].empty()) << "seed " << seed;
    EXPECT_GE(replay["min_clearance_m"].get<double>(), weldtwin::ReplaySetting().min_clearance_m)
        << "seed " << seed;
    EXPECT_LT(replay["true_seam_error_max_m"].get<double>(), 0.001) << "seed " << seed;
    for (const auto& s : replay["true_seam_error"]) {
      EXPECT_GT(s["samples"].get<int>(), 0) << "seed " << seed << " seam " << s["seam"];
      EXPECT_LT(s["max_m"].get<double>(), 0.001) << "seed " << seed << " seam " << s["seam"];
      EXPECT_LE(s["rms_m"].get<double>(), s["max_m"].get<double>() + 1e-12);
    }
    // The localization error the report states is what the torch inherits: it cannot land closer than
    // tracking allows.
    EXPECT_LT(std::abs(replay["true_seam_error_max_m"].get<double>() -
                       r["localization"]["seam_error_max_m"].get<double>()),
              2e-4)
        << "seed " << seed;
  }
  std::printf("%s: %d of 10 seeded cells PASS\n", g_cell.c_str(), passed);
}

// A cell with a rescan (scenes/cells/quick_sweep.yaml, one pass and its crossing pass): swept again only
// where the part is not found in the first sweep, and then sought in both. Seeds 1 and 9 of its part at
// the real scan's noise (benchmarks/localize_survey with --sweep one_pass.yaml --rescan crossing_pass.yaml):
// found in the first sweep, and found only in both.
TEST(Run, ACellsRescanIsSweptOnlyWhenThePartIsNotFoundInTheFirstSweep) {
  for (const int seed : {1, 9}) {
    int code = -1;
    const nlohmann::json r = run_seed(seed, code, "_rescan");
    ASSERT_TRUE(r.is_object()) << "seed " << seed << ": no report.json (exit " << code << ")";
    const std::string dir = ::testing::TempDir() + "weldtwin_run_quick_sweep_rescan_" + std::to_string(seed);
    const bool rescanned = seed == 9;
    ASSERT_EQ(r["sweeps"].size(), rescanned ? 2u : 1u) << "seed " << seed << ": " << r["sweeps"];
    EXPECT_NE(r["sweeps"][0].get<std::string>().find("one_pass.yaml"), std::string::npos);
    EXPECT_EQ(std::filesystem::exists(dir + "/rescan.scanlog"), rescanned) << "seed " << seed;
    EXPECT_TRUE(r["localization"]["found"].get<bool>()) << "seed " << seed << ": " << r["reasons"];
    EXPECT_LT(r["localization"]["seam_error_max_m"].get<double>(), 0.001) << "seed " << seed;
    if (rescanned) {
      EXPECT_NE(r["sweeps"][1].get<std::string>().find("crossing_pass.yaml"), std::string::npos);
      // The part is sought in both sweeps: the scan holds the points of both (about 68 k each).
      EXPECT_GT(r["scan_points"].get<int>(), 120000) << "seed " << seed;
    } else {
      EXPECT_LT(r["scan_points"].get<int>(), 80000) << "seed " << seed;
    }
  }
}

// The same cell at the twin's default LiDAR noise (2.4 times the real scan's), where a square tube's turn
// needs more than the two mid passes: the cell's rescans are swept in turn while the part is not found, or is
// found with a bound that its 99 % region would not accept, each kept as its own log, and the part sought in
// all sweeps so far. Seed 4 is refused twice and found after the outer passes (3 sweeps); seed 5 is found
// after the crossing pass, its turn within 0.49 deg (95 %) but 0.58 deg at 99 %, and swept again (3); seed 2
// is found after the inner pass (4 sweeps), its turn within 0.44 deg but 0.53 deg at 99 %, and swept a fifth
// time (the inner pass with the plane tilted the other way).
TEST(Run, ACellsRescansAreSweptInTurnWhileThePartIsNotFound) {
  const std::string cell = weldtwin::test::at_twin_noise(
      "scenes/cells/quick_sweep.yaml", ::testing::TempDir() + "quick_sweep_twin_noise.yaml");
  for (const auto& [seed, sweeps] : {std::pair<int, size_t>{4, 3}, {5, 3}, {2, 5}}) {
    int code = -1;
    const nlohmann::json r = run_seed(seed, code, "", cell);
    ASSERT_TRUE(r.is_object()) << "seed " << seed << ": no report.json (exit " << code << ")";
    const std::string dir =
        ::testing::TempDir() + "weldtwin_run_quick_sweep_twin_noise_" + std::to_string(seed);
    ASSERT_EQ(r["sweeps"].size(), sweeps) << "seed " << seed << ": " << r["sweeps"];
    const char* programs[] = {"one_pass.yaml", "crossing_pass.yaml", "outer_passes.yaml", "inner_pass.yaml",
                              "inner_plus_pass.yaml"};
    const char* logs[] = {"scan", "rescan", "rescan2", "rescan3", "rescan4"};
    for (size_t k = 0; k < 5; ++k) {
      if (k < sweeps) {
        EXPECT_NE(r["sweeps"][k].get<std::string>().find(programs[k]), std::string::npos) << r["sweeps"];
      }
      EXPECT_EQ(std::filesystem::exists(dir + "/" + logs[k] + ".scanlog"), k < sweeps) << logs[k];
    }
    EXPECT_TRUE(r["localization"]["found"].get<bool>()) << "seed " << seed << ": " << r["reasons"];
    EXPECT_LT(r["localization"]["seam_error_max_m"].get<double>(), 0.001) << "seed " << seed;
    // Why each rescan was swept.
    ASSERT_EQ(r["rescan_reasons"].size(), sweeps - 1) << r["rescan_reasons"];
    EXPECT_EQ(r["rescan_reasons"][0], "the part was not found");
    EXPECT_EQ(
        r["rescan_reasons"][1].get<std::string>().find("the part was found, its turn within 0.49 deg (95 %) "
                                                       "but 0.58 deg at 99 %") == 0,
        seed == 5)
        << r["rescan_reasons"];
    // Sought in all sweeps: about 68 k points each (the outer passes' two, 2 x 45 k or so).
    EXPECT_GT(r["scan_points"].get<int>(), 60000 * static_cast<int>(sweeps)) << "seed " << seed;
  }
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  g_cell = argc > 1 ? argv[1] : "scenes/cells/default.yaml";
  return RUN_ALL_TESTS();
}
