// `weldtwin bench` and `bench-report` as a user runs them: a run split into shards (on "other machines")
// merges into exactly the lines of the unsharded run; a crashing, hanging or throwing trial is recorded with
// its cause and the run goes on; the summary's rates, intervals and percentiles are right on hand-made lines;
// malformed or mismatched shards are refused.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("weldtwin_bench_test_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

int weldtwin(const std::string& args, const fs::path& err) {
  const std::string cmd = std::string(WELDTWIN_BINARY) + " " + args + " >/dev/null 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<json> lines(const fs::path& file, bool drop_timings) {
  std::vector<json> out;
  std::ifstream in(file);
  for (std::string l; std::getline(in, l);) {
    json j = json::parse(l);
    if (drop_timings) j.erase("seconds");
    out.push_back(j);
  }
  return out;
}

TEST(Bench, ShardsMergedEqualTheUnshardedRun) {
  const fs::path d = temp_dir("shards");
  const std::string common = "bench --trials 5 --seed 11 --no-paper -q ";
  ASSERT_EQ(weldtwin(common + "--jobs 2 --out " + (d / "all.jsonl").string(), d / "err"), 0)
      << slurp(d / "err");
  // Shards in another order of work (one at a time), as on other machines; given to the merge out of order.
  ASSERT_EQ(weldtwin(common + "--jobs 1 --shard 1/2 --out " + (d / "s1.jsonl").string(), d / "err"), 0);
  ASSERT_EQ(weldtwin(common + "--jobs 1 --shard 0/2 --out " + (d / "s0.jsonl").string(), d / "err"), 0);
  EXPECT_EQ(lines(d / "s0.jsonl", true).size(), 3u);
  EXPECT_EQ(lines(d / "s1.jsonl", true).size(), 2u);
  ASSERT_EQ(weldtwin("bench-report " + (d / "s1.jsonl").string() + " " + (d / "s0.jsonl").string() +
                         " --out " + (d / "merged").string(),
                     d / "err"),
            0)
      << slurp(d / "err");
  ASSERT_EQ(
      weldtwin("bench-report " + (d / "all.jsonl").string() + " --out " + (d / "single").string(), d / "err"),
      0);

  const std::vector<json> all = lines(d / "all.jsonl", true),
                          merged = lines(d / "merged/results.jsonl", true);
  ASSERT_EQ(all.size(), 5u);
  EXPECT_EQ(all, merged);  // same seed, other processes and order: the same trials, bit for bit
  std::set<std::string> draws;
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i]["index"].get<size_t>(), i) << "lines in index order";
    draws.insert(all[i]["draw"].dump());
    EXPECT_TRUE(all[i].contains("ours"));
    EXPECT_TRUE(all[i]["verdict"] == "pass" || all[i].contains("cause")) << all[i].dump();
  }
  EXPECT_EQ(draws.size(), 5u) << "every trial draws its own cell";
  json a = json::parse(slurp(d / "single/summary.json")), b = json::parse(slurp(d / "merged/summary.json"));
  a.erase("seconds");
  b.erase("seconds");
  EXPECT_EQ(a, b);
  // A stopped run resumed: its finished lines kept (the cut-off one dropped), the rest run, the same lines.
  {
    const std::string all_text = [&] {
      std::ifstream in(d / "all.jsonl");
      return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }();
    const size_t two = all_text.find('\n', all_text.find('\n') + 1) + 1;
    std::ofstream(d / "stopped.jsonl")
        << all_text.substr(0, two) << all_text.substr(two, 50);  // 2 lines and a bit
    ASSERT_EQ(weldtwin(common + "--jobs 2 --resume --out " + (d / "stopped.jsonl").string(), d / "err"), 0)
        << slurp(d / "err");
    EXPECT_EQ(lines(d / "stopped.jsonl", true), all);
    const std::vector<json> kept = lines(d / "stopped.jsonl", false), before = lines(d / "all.jsonl", false);
    EXPECT_EQ(kept[0]["seconds"], before[0]["seconds"]) << "kept, not run again";
    EXPECT_EQ(kept[1]["seconds"], before[1]["seconds"]);
  }
  // Another seed draws other cells.
  ASSERT_EQ(
      weldtwin("bench --trials 1 --seed 12 --no-paper --no-replay -q --out " + (d / "other.jsonl").string(),
               d / "err"),
      0);
  EXPECT_NE(lines(d / "other.jsonl", true)[0]["draw"], all[0]["draw"]);
}

TEST(Bench, CrashingHangingAndThrowingTrialsAreRecordedAndTheRunGoesOn) {
  const fs::path d = temp_dir("faults");
  ASSERT_EQ(
      weldtwin("bench --trials 5 --seed 3 --jobs 2 --no-paper --no-replay -q --timeout-s 20 --fault 1:crash "
               "--fault 2:hang --fault 3:throw --out " +
                   (d / "r.jsonl").string(),
               d / "err"),
      0)
      << slurp(d / "err");
  const std::vector<json> r = lines(d / "r.jsonl", false);
  ASSERT_EQ(r.size(), 5u);
  for (size_t i : {0u, 4u}) EXPECT_TRUE(r[i].contains("ours")) << r[i].dump();
  EXPECT_EQ(r[1]["verdict"], "fail");
  EXPECT_EQ(r[1]["cause_kind"], "crash");
  EXPECT_NE(r[1]["cause"].get<std::string>().find("signal 11"), std::string::npos) << r[1]["cause"];
  EXPECT_EQ(r[2]["cause_kind"], "timeout");
  EXPECT_GE(r[2]["seconds"]["total"].get<double>(), 20.0);
  EXPECT_EQ(r[3]["cause_kind"], "error");
  EXPECT_NE(r[3]["cause"].get<std::string>().find("fault injected"), std::string::npos);
  for (size_t i : {1u, 2u, 3u}) {
    EXPECT_FALSE(r[i]["seams_under_1mm"].get<bool>());
    EXPECT_TRUE(r[i]["draw"].contains("part")) << "the failed trial's cell is still known";
  }
}

TEST(Bench, ResultsThatCannotBeWrittenStopTheRunNamingTheFile) {
  // /dev/full takes the file open and refuses every byte: the run must stop with one line naming it and
  // exit 2, not report trials it did not save. With --resume it must not read the device's endless zeros.
  const fs::path d = temp_dir("full");
  for (const char* resume : {"", " --resume"}) {
    EXPECT_EQ(
        weldtwin(std::string("bench --trials 4 --seed 3 --jobs 1 --no-paper --no-replay -q --out /dev/full") +
                     resume,
                 d / "err"),
        2)
        << resume;
    const std::string err = slurp(d / "err");
    EXPECT_NE(err.find("/dev/full: cannot be written"), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
}

// Hand-made lines with known figures: 10 trials of two parts, 9 within 1 mm.
TEST(BenchReport, RatesIntervalsAndPercentilesAreRight) {
  const fs::path d = temp_dir("summary");
  {
    std::ofstream out(d / "r.jsonl");
    for (int i = 0; i < 10; ++i) {
      json j;
      j["index"] = i;
      j["seed"] = 5;
      j["draw"] = {{"part", i < 6 ? "a" : "b"}, {"yaw_deg", 36.0 * i}, {"clamps", 2 + i % 3}};
      const double mm = 0.1 * (i + 1);  // 0.1 .. 1.0, and trial 9 off by 4 mm
      j["ours"] = {{"found", true},
                   {"seam_max_mm", i == 9 ? 4.0 : mm},
                   {"rotation_deg", 0.01 * i},
                   {"success", i != 9}};
      j["paper"] = {{"found", true}, {"seam_max_mm", 10.0 + i}, {"rotation_deg", 1.0}, {"success", false}};
      j["seams_under_1mm"] = i != 9;
      j["verdict"] = i < 7 ? "pass" : "fail";
      if (i >= 7) {
        j["cause"] = i == 9 ? "localization: seam 4.000 mm off" : "plan: seam 'x' unreachable at 12.5 deg";
        j["cause_kind"] = i == 9 ? "localization" : "plan";
      }
      // Trials 7 and 8 failed though found right: 7's suggestion welded, 8 had none.
      if (i == 7)
        j["guidance"] = {{"found", true}, {"instruction", "move"}, {"tried", {{"verdict", "pass"}}}};
      if (i == 8) j["guidance"] = {{"found", false}, {"reason", "none"}};
      j["seconds"] = {{"sweep", 1.0 + i}, {"total", 2.0 + i}};
      if (i < 4) j["calibration"] = {{"translation_error_mm", 0.1 * (i + 1)}, {"rotation_error_deg", 0.01}};
      out << j.dump() << '\n';
    }
  }
  ASSERT_EQ(
      weldtwin("bench-report " + (d / "r.jsonl").string() + " --out " + (d / "rep").string(), d / "err"), 0)
      << slurp(d / "err");
  const json s = json::parse(slurp(d / "rep/summary.json"));
  const json& all = s["overall"];
  EXPECT_EQ(s["trials"], 10);
  EXPECT_EQ(all["ours"]["seams_under_1mm"]["count"], 9);
  EXPECT_DOUBLE_EQ(all["ours"]["seams_under_1mm"]["rate"].get<double>(), 0.9);
  // Wilson score interval for 9 of 10 at 95 %: 0.5958 .. 0.9821.
  EXPECT_NEAR(all["ours"]["seams_under_1mm"]["ci95"][0].get<double>(), 0.5958, 1e-3);
  EXPECT_NEAR(all["ours"]["seams_under_1mm"]["ci95"][1].get<double>(), 0.9821, 1e-3);
  EXPECT_EQ(all["ours"]["false_accepts"], 1);
  EXPECT_EQ(all["paper"]["seams_under_1mm"]["count"], 0);
  EXPECT_DOUBLE_EQ(all["ours"]["seam_max_mm"]["max"].get<double>(), 4.0);
  EXPECT_NEAR(all["ours"]["seam_max_mm"]["median"].get<double>(), 0.55, 0.051);  // 0.5 or 0.6 of ten
  EXPECT_EQ(s["parts"]["a"]["trials"], 6);
  EXPECT_EQ(s["parts"]["b"]["ours"]["seams_under_1mm"]["count"], 3);
  EXPECT_EQ(all["welded"]["count"], 7);
  EXPECT_EQ(all["guidance"]["failures_found_right"], 2);
  EXPECT_EQ(all["guidance"]["suggested"]["count"], 1);
  EXPECT_EQ(all["guidance"]["suggestion_welded"]["count"], 1);
  EXPECT_FALSE(s["parts"]["a"].contains("guidance")) << "part a had no failure asked about";
  EXPECT_EQ(s["parts"]["b"]["guidance"]["suggestion_welded"]["count"], 1);
  EXPECT_DOUBLE_EQ(s["seconds"]["sweep"]["max"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(s["seconds"]["sweep"]["mean"].get<double>(), 5.5);
  EXPECT_EQ(s["failure_kinds"]["plan"], 2);
  EXPECT_EQ(s["calibration"]["translation_error_mm"]["n"], 4);
  EXPECT_DOUBLE_EQ(s["calibration"]["translation_error_mm"]["max"].get<double>(), 0.4);
  // Causes alike but for their numbers count together.
  ASSERT_GE(s["failure_causes"].size(), 1u);
  EXPECT_EQ(s["failure_causes"][0]["count"], 2);
  EXPECT_EQ(s["failure_causes"][0]["cause"], "plan: seam 'x' unreachable at # deg");
  const std::string page = slurp(d / "rep/report.html");
  EXPECT_NE(page.find("90.0 %"), std::string::npos);
  // The page leads with what was welded.
  EXPECT_LT(page.find("Welded end to end"), page.find("<h2>Success"));
  EXPECT_EQ(page.find("src=\"http"), std::string::npos) << "self-contained";
}

TEST(BenchReport, RefusesMalformedAndMismatchedShards) {
  const fs::path d = temp_dir("bad");
  const std::string good = R"({"draw":{"part":"a"},"index":0,"seed":1,"seconds":{},"verdict":"pass"})";
  std::ofstream(d / "good.jsonl") << good << '\n';
  std::ofstream(d / "truncated.jsonl") << good << "\n{\"draw\":{\"part\":\"a\"},\"ind";
  std::ofstream(d / "other_seed.jsonl")
      << R"({"draw":{},"index":1,"seed":2,"seconds":{},"verdict":"pass"})" << '\n';
  std::ofstream(d / "conflict.jsonl")
      << R"({"draw":{"part":"a"},"index":0,"seed":1,"seconds":{},"verdict":"fail"})" << '\n';
  std::ofstream(d / "empty.jsonl") << "";
  const std::pair<std::string, std::string> cases[] = {
      {"truncated.jsonl", "line 2 is not JSON"},
      {"other_seed.jsonl", "different benchmarks"},
      {"conflict.jsonl", "different results"},
      {"empty.jsonl", "no trials"},
  };
  for (const auto& [file, message] : cases) {
    const std::string args =
        file == "empty.jsonl" ? (d / file).string() : (d / "good.jsonl").string() + " " + (d / file).string();
    EXPECT_EQ(weldtwin("bench-report " + args + " --out " + (d / "rep").string(), d / "err"), 2) << file;
    const std::string err = slurp(d / "err");
    EXPECT_NE(err.find(message), std::string::npos) << file << ": " << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  }
  // The same trial in two shards with the same result (a shard re-run) is fine.
  EXPECT_EQ(weldtwin("bench-report " + (d / "good.jsonl").string() + " " + (d / "good.jsonl").string() +
                         " --out " + (d / "rep").string(),
                     d / "err"),
            0)
      << slurp(d / "err");
  // Options out of range are refused before any trial runs, in one line naming the option.
  for (const char* option : {"--shard 3/3", "--jobs -2", "--timeout-s 0", "--timeout-s -1",
                             "--replay-step-ms 0", "--mount-error-mm -1", "--encoder-noise-rad -0.1"}) {
    const std::string bad = option;
    fs::remove(d / "x.jsonl");
    EXPECT_EQ(weldtwin("bench --trials 3 " + bad + " --out " + (d / "x.jsonl").string(), d / "err"), 2)
        << bad;
    const std::string err = slurp(d / "err");
    EXPECT_NE(err.find(bad.substr(0, bad.find(' '))), std::string::npos) << bad << ": " << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_FALSE(fs::exists(d / "x.jsonl")) << bad;
  }
}

}  // namespace
}  // namespace weldtwin
