// Speed of the closed-form IK: all 8 solutions of a pose, with their precision polish.
#include <benchmark/benchmark.h>

#include <random>

#include "planning/ik_aubo.hpp"

namespace weldtwin {
namespace {

void BM_IkSolveAll(benchmark::State& state) {
  static const RobotModel robot =
      RobotModel::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/robots/aubo_i5.urdf");
  const AuboIk ik(robot, "tcp");
  std::mt19937_64 rng(3);
  std::vector<Iso3> poses;
  for (int k = 0; k < 1024; ++k) {
    JointVector q;
    for (int j = 0; j < 6; ++j) q[j] = std::uniform_real_distribution<double>(-3.0, 3.0)(rng);
    poses.push_back(ik.fk(q));
  }
  size_t i = 0, valid = 0;
  for (auto _ : state) {
    const auto sols = ik.solve(poses[i++ & 1023]);
    valid += sols[0].valid;
  }
  benchmark::DoNotOptimize(valid);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_IkSolveAll);

}  // namespace
}  // namespace weldtwin

BENCHMARK_MAIN();
