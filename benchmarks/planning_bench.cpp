// Speed of the closed-form IK: all 8 solutions of a pose, with their precision polish.
#include <benchmark/benchmark.h>

#include <random>

#include "core/part_spec.hpp"
#include "planning/ik_aubo.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {
namespace {

// TCP poses of 1024 seeded random configurations.
std::vector<Iso3> random_poses(const RobotModel& robot) {
  std::mt19937_64 rng(3);
  std::vector<Iso3> poses;
  for (int k = 0; k < 1024; ++k) {
    JointVector q;
    for (int j = 0; j < 6; ++j) q[j] = std::uniform_real_distribution<double>(-3.0, 3.0)(rng);
    poses.push_back(robot.forward_kinematics(q, robot.require_link("tcp")));
  }
  return poses;
}

// The arm, its IK at the TCP, and the poses to solve, shared by the IK benchmarks.
struct IkFixture {
  RobotModel robot = RobotModel::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/robots/aubo_i5.urdf");
  AuboIk ik{robot, "tcp"};
  std::vector<Iso3> poses = random_poses(robot);
};

const IkFixture& ik_fixture() {
  static const IkFixture f;
  return f;
}

void BM_IkSolveAll(benchmark::State& state) {
  const IkFixture& f = ik_fixture();
  const AuboIk& ik = f.ik;
  const std::vector<Iso3>& poses = f.poses;
  size_t i = 0, valid = 0;
  for (auto _ : state) {
    const auto sols = ik.solve(poses[i++ & 1023]);
    valid += sols[0].valid;
  }
  benchmark::DoNotOptimize(valid);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_IkSolveAll);

// One branch, as the planner asks for it at every 200 Hz sample.
void BM_IkSolveBranch(benchmark::State& state) {
  const IkFixture& f = ik_fixture();
  const AuboIk& ik = f.ik;
  const std::vector<Iso3>& poses = f.poses;
  size_t i = 0, valid = 0;
  for (auto _ : state) {
    valid += ik.solve_branch(poses[i & 1023], static_cast<int>(i & 7)).valid;
    ++i;
  }
  benchmark::DoNotOptimize(valid);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_IkSolveBranch);

// Planning a whole part at its cell's pose: roll and branch choice, IK of every 200 Hz sample, limit checks.
void BM_PlanPart(benchmark::State& state) {
  static const char* parts[] = {"tube_on_plate", "round_on_plate", "tube_tee"};
  const std::string root = WELDTWIN_SOURCE_DIR;
  const RobotModel robot = RobotModel::load(root + "/scenes/robots/aubo_i5.urdf");
  const PartSpec part = PartSpec::load(root + "/scenes/parts/" + parts[state.range(0)] + ".yaml");
  const Iso3 pose = planar_pose(0.46, 0.05, 0.0, 0.4);
  size_t samples = 0;
  bool ok = true;
  for (auto _ : state) {
    const WeldPlan plan = plan_welds(part, pose, robot);
    samples = plan.samples.size();
    ok = ok && plan.ok();
  }
  state.SetLabel(std::string(parts[state.range(0)]) + (ok ? "" : " (NOT PLANNED)"));
  state.counters["samples"] = static_cast<double>(samples);
}
BENCHMARK(BM_PlanPart)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace weldtwin

BENCHMARK_MAIN();
