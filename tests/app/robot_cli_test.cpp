// The robot switch and its gate, as a user meets them: `weldtwin run --robot aubo://... --execute` against a
// fake controller on loopback sends the plan of DIR/plan.json sample for sample (its SHA-256, checked with
// sha256sum, named by the passed report), planned and replayed from where the arm stands; a run whose replay
// failed is refused with nothing sent that moves the arm; a controller fault ends in exit 3 with the record
// kept; Ctrl-C mid-weld stops the arm, exit 130; a live sweep (fake A2 + fake controller) runs the sweep
// program on the arm and is kept as a recording. The gate itself: a plan changed after its replay, a failed
// or missing report — refused.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "app/robot_gate.hpp"
#include "core/scan_log.hpp"
#include "planning/weld_planner.hpp"
#include "sim/sweep_program.hpp"
#include "tests/support/fake_a2.hpp"
#include "tests/support/fake_aubo.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / "weldtwin_robot_cli_test" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

struct Child {
  pid_t pid = -1;
  fs::path out, err;
};

// Starts `weldtwin run ...` with stdout and stderr in files.
Child start(const std::string& args, const fs::path& dir) {
  Child c;
  c.out = dir / "stdout.txt";
  c.err = dir / "stderr.txt";
  c.pid = fork();
  if (c.pid == 0) {
    const std::string cmd = std::string("exec ") + WELDTWIN_BINARY + " run " + args + " >" + c.out.string() +
                            " 2>" + c.err.string();
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return c;
}

int finish(const Child& c) {
  int status = 0;
  waitpid(c.pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

test::FakeAuboSetting at_home(double time_scale) {
  test::FakeAuboSetting s;
  s.start_q = PlanSetting().home;
  s.time_scale = time_scale;
  return s;
}

TEST(RobotCli, ExecuteSendsThePassedPlanSampleForSample) {
  const fs::path dir = temp_dir("execute");
  test::FakeAubo controller(at_home(100.0));  // a 50 s plan in half a second
  const Child c = start(
      "--no-renders --robot " + controller.spec() + " --execute --speed 0.8 --out " + (dir / "run").string(),
      dir);
  ASSERT_EQ(finish(c), 0) << slurp(c.out) << slurp(c.err);
  EXPECT_NE(slurp(c.out).find("; executed on aubo://127.0.0.1"), std::string::npos) << slurp(c.out);

  const nlohmann::json plan = nlohmann::json::parse(slurp(dir / "run/plan.json"));
  const std::vector<JointVector> sent = controller.path();
  ASSERT_EQ(sent.size(), plan["samples"].size());
  for (size_t i = 0; i < sent.size(); ++i)
    for (int j = 0; j < 6; ++j)
      ASSERT_EQ(sent[i][j], plan["samples"][i]["q"][static_cast<size_t>(j)].get<double>()) << i << " " << j;
  EXPECT_DOUBLE_EQ(controller.path_dt(), 0.005);
  EXPECT_DOUBLE_EQ(controller.speed_fraction(), 0.8);
  EXPECT_TRUE(controller.protocol_errors().empty()) << controller.protocol_errors().front();
  EXPECT_FALSE(controller.moving());

  // The hash in the passed report is the plan file's (checked by another tool), and the record names it.
  ASSERT_EQ(
      std::system(
          ("sha256sum " + (dir / "run/plan.json").string() + " >" + (dir / "sum.txt").string()).c_str()),
      0);
  const std::string sum = slurp(dir / "sum.txt").substr(0, 64);
  const nlohmann::json report = nlohmann::json::parse(slurp(dir / "run/report.json"));
  EXPECT_EQ(report["verdict"], "PASS");
  EXPECT_EQ(report["plan"]["sha256"], sum);
  const nlohmann::json record = nlohmann::json::parse(slurp(dir / "run/execution.json"));
  EXPECT_EQ(record["plan_sha256"], sum);
  EXPECT_EQ(record["outcome"], "completed");
  EXPECT_GT(record["joints"]["t_s"].size(), 20u);
}

TEST(RobotCli, AnArmAwayFromHomeIsPlannedAndReplayedFromWhereItStands) {
  const fs::path dir = temp_dir("away");
  test::FakeAuboSetting s = at_home(100.0);
  s.start_q = SweepProgram::load(test::repo("scenes/sweeps/default.yaml"),
                                 RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf")))
                  .start();  // where a sweep leaves it... or starts: anywhere but home
  test::FakeAubo controller(s);
  const Child c = start(
      "--no-renders -q --robot " + controller.spec() + " --execute --out " + (dir / "run").string(), dir);
  ASSERT_EQ(finish(c), 0) << slurp(c.out) << slurp(c.err);
  const nlohmann::json plan = nlohmann::json::parse(slurp(dir / "run/plan.json"));
  for (int j = 0; j < 6; ++j)
    EXPECT_EQ(plan["samples"][0]["q"][static_cast<size_t>(j)].get<double>(), s.start_q[j]) << j;
  EXPECT_EQ(controller.path().size(), plan["samples"].size());
  EXPECT_TRUE(controller.protocol_errors().empty()) << controller.protocol_errors().front();
}

TEST(RobotCli, ExecuteIsRefusedWithoutAPassedReplay) {
  const fs::path dir = temp_dir("refused");
  test::FakeAubo controller(at_home(100.0));
  // The LiDAR's mount 5 mm off and not calibrated: the part is found 5 mm off, the replay fails.
  const Child c = start("--no-renders --mount-error-mm 5 0 0 --mount-error-deg 0 0 0 --robot " +
                            controller.spec() + " --execute --out " + (dir / "run").string(),
                        dir);
  EXPECT_EQ(finish(c), 3) << slurp(c.err);
  const std::string out = slurp(c.out);
  EXPECT_NE(out.find("FAIL: --execute refused: the run did not pass"), std::string::npos) << out;
  EXPECT_NE(out.find("the plan was not sent to aubo://127.0.0.1"), std::string::npos) << out;
  // The arm's state was read (to plan from where it stands); nothing that moves it was sent.
  for (const std::string& m : controller.methods())
    EXPECT_TRUE(m == "__login__" || m == "getRobotNames" || m.rfind("rob1.RobotState.", 0) == 0) << m;
  EXPECT_TRUE(controller.path().empty());
  EXPECT_FALSE(fs::exists(dir / "run/execution.json"));
}

TEST(RobotCli, AControllerFaultIsExit3WithTheRecordKept) {
  const fs::path dir = temp_dir("fault");
  test::FakeAuboSetting s = at_home(100.0);
  s.fault_at = 0.4;
  test::FakeAubo controller(s);
  const Child c = start(
      "--no-renders -q --robot " + controller.spec() + " --execute --out " + (dir / "run").string(), dir);
  EXPECT_EQ(finish(c), 3) << slurp(c.err);
  const std::string out = slurp(c.out);
  EXPECT_NE(out.find("FAIL: robot: aubo://127.0.0.1"), std::string::npos) << out;
  EXPECT_NE(out.find("controller fault: safety mode ProtectiveStop; stop sent, the arm halted"),
            std::string::npos)
      << out;
  EXPECT_GE(controller.stops(), 1);
  const nlohmann::json record = nlohmann::json::parse(slurp(dir / "run/execution.json"));
  EXPECT_NE(record["outcome"].get<std::string>().find("ProtectiveStop"), std::string::npos);
}

TEST(RobotCli, CtrlCMidWeldStopsTheArm) {
  const fs::path dir = temp_dir("sigint");
  test::FakeAubo controller(at_home(1.0));  // real time: the weld takes ~50 s
  const Child c =
      start("--no-renders --robot " + controller.spec() + " --execute --out " + (dir / "run").string(), dir);
  for (int k = 0; k < 600 && !controller.moving(); ++k) usleep(100000);
  ASSERT_TRUE(controller.moving()) << slurp(c.err);
  usleep(300000);
  kill(c.pid, SIGINT);
  EXPECT_EQ(finish(c), 130) << slurp(c.err);
  EXPECT_GE(controller.stops(), 1);
  EXPECT_FALSE(controller.moving());
  EXPECT_LT(controller.progress(), 0.2);
  EXPECT_NE(slurp(c.out).find("stopped on request (SIGINT); stop sent, the arm halted"), std::string::npos)
      << slurp(c.out);
}

TEST(RobotCli, ALiveSweepMovesTheArmAndIsRecorded) {
  const fs::path dir = temp_dir("live");
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  const SweepProgram program = SweepProgram::load(test::repo("scenes/sweeps/default.yaml"), robot);
  test::FakeAuboSetting s = at_home(100.0);  // the 181 s sweep in under 2 s
  s.start_q = program.start();
  test::FakeAubo controller(s);
  test::FakeA2 lidar;  // a LiDAR that sees a 1.0-1.4 m ring: no table, no part
  const Child c = start("--no-renders -q --source lidar:" + lidar.port() + " --robot " + controller.spec() +
                            " --execute --out " + (dir / "run").string(),
                        dir);
  EXPECT_EQ(finish(c), 3) << slurp(c.err);
  // Which check refuses the ring depends on how the live turns fell against the joint states (no table plane,
  // or a best match covering too little of the model when the machine is busy): that the part is not found.
  EXPECT_NE(slurp(c.out).find("the run did not pass (part not found: "), std::string::npos)
      << slurp(c.out) << slurp(c.err);
  // The controller ran the sweep program (and nothing else: no part, no plan).
  const size_t samples = static_cast<size_t>(std::ceil(program.duration_s() / 0.005)) + 1;
  EXPECT_EQ(controller.path().size(), samples);
  EXPECT_TRUE(controller.protocol_errors().empty()) << controller.protocol_errors().front();
  // The sweep is kept as a cell recording with the controller's joint states.
  const ScanLog log = ScanLog::read((dir / "run/scan.scanlog").string());
  EXPECT_EQ(log.source, "cell");
  EXPECT_GT(log.joints.size(), 100u);
  EXPECT_GT(log.turns.size(), 10u);
  EXPECT_LT((log.joints.back().q - program.q(program.duration_s())).norm(), 1e-6);
  EXPECT_GT(lidar.stops(), 0);
  EXPECT_EQ(lidar.last_pwm(), 0);  // the motor stopped
}

TEST(RobotGate, OnlyThePlanOfAPassedReplayGetsThrough) {
  const fs::path dir = temp_dir("gate");
  nlohmann::json plan;
  for (int i = 0; i < 5; ++i)
    plan["samples"].push_back({{"t", 0.005 * i}, {"q", {0.1 * i, 0, 1.5, 0, 1.5, 0}}});
  std::ofstream(dir / "plan.json") << plan.dump() << '\n';
  nlohmann::json report = {{"verdict", "PASS"},
                           {"replay", {{"passed", true}}},
                           {"plan", {{"sha256", sha256_of_file((dir / "plan.json").string())}}}};
  std::ofstream(dir / "report.json") << report.dump();
  const GatedPlan g = open_gate(dir.string());
  ASSERT_EQ(g.trajectory.q.size(), 5u);
  EXPECT_DOUBLE_EQ(g.trajectory.q[4][0], 0.4);
  EXPECT_DOUBLE_EQ(g.trajectory.dt_s, 0.005);

  auto refused = [&](const std::string& why) {
    try {
      open_gate(dir.string());
      ADD_FAILURE() << "not refused: " << why;
    } catch (const GateRefused& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  plan["samples"][2]["q"][0] = 0.25;  // changed after the replay
  std::ofstream(dir / "plan.json") << plan.dump() << '\n';
  refused("changed since its replay");
  report["plan"]["sha256"] = sha256_of_file((dir / "plan.json").string());
  report["verdict"] = "FAIL";
  report["reasons"] = {"replay: the torch touches clamp0_arm"};
  std::ofstream(dir / "report.json") << report.dump();
  refused("the run did not pass (replay: the torch touches clamp0_arm)");
  report["verdict"] = "PASS";
  report["replay"]["passed"] = false;
  std::ofstream(dir / "report.json") << report.dump();
  refused("replay in the twin did not pass");
  fs::remove(dir / "report.json");
  refused("no report");
  // The test vector of FIPS 180-2.
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

}  // namespace
}  // namespace weldtwin
