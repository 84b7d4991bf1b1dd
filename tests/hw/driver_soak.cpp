// A randomized soak of the Aubo driver against the fake controller: every run executes a 2 s trajectory
// with one fault drawn at a random moment of it — a protective stop, the command or the state connection
// dropped, both connections stalling (a mute controller), garbage on either socket, or a stop request — and
// checks that it ended as the driver promises:
//   - execute() returns (the fault did no harm) or throws RobotError, nothing else;
//   - when the arm moved and the run failed, a stop was sent and the arm stands short of the path's end;
//   - the fake reports no motion once the driver is back;
//   - no thread and no file descriptor is left once the driver and the fake are gone;
//   - the execution record is written, parses, and holds the outcome and every joint state seen.
//
//   driver_soak [--runs N] [--seed S] [--from K] [-v]     (ctest runs 24; benchmarks/RESULTS.md 1000)
#include <dirent.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "hw/execution_record.hpp"
#include "hw/robot_driver.hpp"
#include "tests/support/fake_aubo.hpp"

namespace weldtwin {
namespace {

enum class Fault {
  kProtectiveStop,
  kDropCommands,
  kDropStates,
  kMute,
  kGarbageCommands,
  kGarbageStates,
  kStop
};
constexpr int kFaultKinds = 7;
const char* fault_name(Fault f) {
  switch (f) {
    case Fault::kProtectiveStop:
      return "protective stop";
    case Fault::kDropCommands:
      return "command connection dropped";
    case Fault::kDropStates:
      return "state connection dropped";
    case Fault::kMute:
      return "controller mute";
    case Fault::kGarbageCommands:
      return "garbage on the command socket";
    case Fault::kGarbageStates:
      return "garbage on the state socket";
    case Fault::kStop:
      return "stop request";
  }
  return "?";
}

size_t entries(const char* dir) {
  size_t n = 0;
  if (DIR* d = opendir(dir)) {
    while (readdir(d)) ++n;
    closedir(d);
  }
  return n;
}

// Garbage of four kinds: random bytes, a truncated object, an object of the wrong shape, deep nesting.
std::string garbage(std::mt19937_64& rng) {
  switch (rng() % 4) {
    case 0: {
      std::string s(1 + rng() % 300, '\0');
      for (char& c : s) c = static_cast<char>(rng() & 0xFF);
      return s;
    }
    case 1:
      return R"({"jsonrpc":"2.0","result":[0.1,0.2,)";
    case 2:
      return R"({"R1_actual_q":"six","R1_actual_qd":[1,2],"R1_robot_mode":7,"id":[]})";
    default:
      return std::string(2000, '{');
  }
}

struct Run {
  Fault fault = Fault::kStop;
  double at = 0.0;  ///< fraction of the path
  std::string outcome;
  std::string problem;  ///< empty: every check held
};

JointTrajectory a_move(const JointVector& home) {
  JointTrajectory t;
  const JointVector delta = (JointVector() << 0.4, -0.2, 0.3, 0.25, -0.35, 0.5).finished();
  const int n = 400;  // 2 s at 200 Hz
  for (int i = 0; i <= n; ++i) t.q.push_back(home + delta * 0.5 * (1 - std::cos(kPi * i / n)));
  return t;
}

Run soak_run(uint64_t seed, uint64_t index, const RobotModel& robot, const std::string& scratch) {
  std::mt19937_64 rng(seed * 1000003u + index);
  std::uniform_real_distribution<double> at(0.05, 0.45);
  Run r;
  r.fault = static_cast<Fault>(rng() % kFaultKinds);
  r.at = at(rng);
  const JointVector home = (JointVector() << 0, 0, kPi / 2, 0, kPi / 2, 0).finished();
  const JointTrajectory move = a_move(home);

  const size_t threads_before = entries("/proc/self/task"), fds_before = entries("/proc/self/fd");
  ExecutionLog log;
  bool moved_stopped = false;
  {
    test::FakeAuboSetting fs;
    fs.start_q = home;
    fs.time_scale = 2.0;  // the path runs 1 s
    switch (r.fault) {
      case Fault::kProtectiveStop:
        fs.fault_at = r.at;
        break;
      case Fault::kDropCommands:
        fs.drop_rpc_at = r.at;
        break;
      case Fault::kDropStates:
        fs.drop_rtde_at = r.at;
        break;
      case Fault::kMute:
        fs.mute_at = r.at;
        break;
      case Fault::kGarbageCommands:
        fs.garbage_rpc_at = r.at, fs.garbage = garbage(rng);
        break;
      case Fault::kGarbageStates:
        fs.garbage_rtde_at = r.at, fs.garbage = garbage(rng);
        break;
      case Fault::kStop:
        break;
    }
    test::FakeAubo fake(fs);
    std::atomic<bool> stop{false};
    RobotDriverSetting s;
    s.timeout_s = 0.25;
    s.stop_request = &stop;
    const double stop_at_s = r.at * move.duration_s() / fs.time_scale;
    try {
      auto driver = make_robot_driver(fake.spec(), robot, SimRobotInputs(), s);
      driver->connect();
      try {
        log = driver->execute(move, [&](double, const JointState& js) {
          if (r.fault == Fault::kStop && js.t_s > stop_at_s) stop = true;
        });
        r.outcome = "completed";
        if (fake.progress() < 1.0) r.problem = "completed, but the fake's arm did not reach the path's end";
      } catch (const RobotError& e) {
        r.outcome = e.what();
        log = e.log();
        const bool moved = r.outcome.find("did not move") == std::string::npos &&
                           r.outcome.find("nothing was sent") == std::string::npos;
        if (moved) {
          moved_stopped = true;
          if (r.outcome.find("stop sent") == std::string::npos || fake.stops() < 1)
            r.problem = "failed without a stop sent";
          else if (fake.progress() >= 1.0)
            r.problem = "the arm ran to the path's end before it was stopped";
        }
      }
      if (r.problem.empty() && fake.moving()) r.problem = "the arm is still moving";
      if (r.problem.empty() && !fake.protocol_errors().empty())
        r.problem = "a request the controller refuses: " + fake.protocol_errors().front();
    } catch (const std::exception& e) {
      r.outcome = e.what();
      r.problem = std::string("an exception other than RobotError: ") + e.what();
    }
  }
  if (r.problem.empty()) {
    // The record, as `weldtwin run --robot` writes it, read back.
    const std::string path = scratch + "/execution.json";
    write_execution_record(path, {"aubo://fake", "0", 1.0, log, r.outcome});
    std::ifstream in(path);
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_discarded() || j.value("outcome", "") != r.outcome ||
        j["joints"]["t_s"].size() != log.joints.size())
      r.problem = "the record does not hold the outcome and the joint states";
    else if (moved_stopped && log.joints.empty())
      r.problem = "the arm moved, but the record holds no joint state";
  }
  if (r.problem.empty()) {
    // Threads may take a moment to be reaped after join; fds close at once.
    size_t threads = entries("/proc/self/task");
    for (int k = 0; k < 50 && threads > threads_before; ++k) {
      usleep(2000);
      threads = entries("/proc/self/task");
    }
    const size_t fds = entries("/proc/self/fd");
    if (threads != threads_before || fds != fds_before)
      r.problem = "left behind: " + std::to_string(threads) + " threads (" + std::to_string(threads_before) +
                  " before), " + std::to_string(fds) + " descriptors (" + std::to_string(fds_before) +
                  " before)";
  }
  return r;
}

}  // namespace
}  // namespace weldtwin

int main(int argc, char** argv) {
  using namespace weldtwin;
  CLI::App app("driver_soak: faults at random moments against the fake controller; exit 1 on any broken run");
  int runs = 24;
  uint64_t seed = 1, from = 0;
  bool verbose = false;
  app.add_option("--runs", runs, "how many seeded runs")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "the soak's seed");
  app.add_option("--from", from, "the first run's index (to repeat one: --from K --runs 1)");
  app.add_flag("-v", verbose, "a line per run");
  CLI11_PARSE(app, argc, argv);

  const RobotModel robot =
      load_cell_robot(CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/default.yaml"));
  const std::string scratch =
      std::filesystem::temp_directory_path() / ("driver_soak_" + std::to_string(getpid()));
  std::filesystem::create_directories(scratch);
  int broken = 0, completed = 0;
  int per_kind[kFaultKinds] = {};
  for (uint64_t i = from; i < from + static_cast<uint64_t>(runs); ++i) {
    const Run r = soak_run(seed, i, robot, scratch);
    ++per_kind[static_cast<int>(r.fault)];
    if (r.outcome == "completed") ++completed;
    if (!r.problem.empty()) ++broken;
    if (verbose || !r.problem.empty())
      std::printf("run %llu: %s at %.2f: %s%s%s\n", static_cast<unsigned long long>(i), fault_name(r.fault),
                  r.at, r.outcome.c_str(), r.problem.empty() ? "" : "  BROKEN: ", r.problem.c_str());
    if (!verbose && (i + 1 - from) % 100 == 0)
      std::fprintf(stderr, "driver_soak: %llu of %d runs, %d broken\n",
                   static_cast<unsigned long long>(i + 1 - from), runs, broken);
  }
  std::filesystem::remove_all(scratch);
  std::printf("driver_soak: %d runs (seed %llu), %d broken, %d completed despite the fault; per fault:", runs,
              static_cast<unsigned long long>(seed), broken, completed);
  for (int k = 0; k < kFaultKinds; ++k)
    std::printf(" %s %d%s", fault_name(static_cast<Fault>(k)), per_kind[k], k + 1 < kFaultKinds ? "," : "\n");
  return broken == 0 ? 0 : 1;
}
