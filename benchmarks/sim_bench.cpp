// Speed of the twin's LiDAR: Embree rays per second on the default cell (against MuJoCo's own mj_ray in the
// same run), and a whole default sweep against its real duration; the sensor's pose per sample; MuJoCo's
// contacts of the arm with and without the early-out in front of its convex collider.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "planning/weld_planner.hpp"
#include "sim/collision_check.hpp"
#include "sim/contact_prefilter.hpp"
#include "sim/contact_screen.hpp"
#include "sim/embree_scene.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {
namespace {

struct DefaultCell {
  CellSpec spec = CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/default.yaml");
  PartSpec part = PartSpec::load(spec.part_spec);
  RobotModel robot = load_cell_robot(spec);
  CellLayout layout = make_layout(spec, part, std::nullopt);
  MujocoWorld world{spec, part, robot, layout};
  SweepProgram program = SweepProgram::load(spec.sweep_program, robot);
};

DefaultCell& cell() {
  static DefaultCell c;
  return c;
}

// Rays as the sweep casts them: from the LiDAR at a mid-sweep pose, all round its scan plane.
std::vector<std::pair<Vec3, Vec3>> lidar_rays(size_t n) {
  DefaultCell& c = cell();
  std::vector<std::pair<Vec3, Vec3>> rays;
  std::mt19937_64 rng(1);
  for (size_t i = 0; i < n; ++i) {
    const JointVector q = c.program.q(std::uniform_real_distribution<double>(0, c.program.duration_s())(rng));
    const Iso3 T = c.robot.forward_kinematics(q, c.robot.require_link("lidar"));
    const double a = std::uniform_real_distribution<double>(0, 2 * kPi)(rng);
    rays.emplace_back(T.translation(), T.linear() * Vec3(std::cos(a), std::sin(a), 0));
  }
  return rays;
}

// One scene for all benchmark threads; each thread casts through its own view.
const EmbreeScene& embree_scene() {
  static const std::unique_ptr<EmbreeScene> scene = [] {
    DefaultCell& c = cell();
    c.world.set_joints(c.world.data(), c.program.q(30.0));
    return std::make_unique<EmbreeScene>(c.world.model(), c.world.data());
  }();
  return *scene;
}

void BM_EmbreeRays(benchmark::State& state) {
  DefaultCell& c = cell();
  const EmbreeScene& scene = embree_scene();
  EmbreeScene::View view = scene.make_view();
  view.update(c.world.data());
  const auto rays = lidar_rays(4096);
  size_t i = 0, hits = 0;
  for (auto _ : state) {
    const auto& r = rays[i++ & 4095];
    hits += view.cast(r.first, r.second, 1e-6, 12.0).hit();
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_EmbreeRays)->Threads(1)->Threads(2)->UseRealTime();

void BM_MjRay(benchmark::State& state) {
  DefaultCell& c = cell();
  embree_scene();  // poses the arm as BM_EmbreeRays has it
  const auto rays = lidar_rays(4096);
  // The groups that are drawn: Embree leaves the collision-only pieces out too.
  const mjtByte drawn[mjNGROUP] = {1, 1, 1, 0, 0, 0};
  size_t i = 0;
  double sum = 0;
  for (auto _ : state) {
    const auto& r = rays[i++ & 4095];
    int geom = -1;
    sum += mj_ray(c.world.model(), c.world.data(), r.first.data(), r.second.data(), drawn, 1, -1, &geom);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_MjRay);

// The whole default sweep (noise on); the counter is simulated seconds per wall second.
void BM_DefaultSweep(benchmark::State& state) {
  DefaultCell& c = cell();
  SweepOptions options;
  options.threads = static_cast<int>(state.range(0));
  double simulated = 0;
  for (auto _ : state) {
    const SweepResult r = simulate_sweep(c.world, c.robot, c.program, LidarSetting(), options);
    benchmark::DoNotOptimize(r.log.samples.data());
    simulated += c.program.duration_s();
  }
  state.counters["x_real_time"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
  state.counters["samples"] = static_cast<double>(c.program.duration_s() * LidarSetting().sample_rate_hz);
}
BENCHMARK(BM_DefaultSweep)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace weldtwin

namespace weldtwin {
namespace {

// The LiDAR's pose per sample: the plain chain product against the cached one, in a base-joint pass.
void BM_LidarPose(benchmark::State& state) {
  DefaultCell& c = cell();
  const RobotModel& arm = c.world.robot();
  const int lidar = arm.require_link("lidar");
  RobotModel::ChainCache cache;
  const bool cached = state.range(0) != 0;
  double t = 0.0, sum = 0.0;
  for (auto _ : state) {
    const JointVector q = c.program.q(2.0 + t);  // inside the first pass: only J1 moves
    t += 1.25e-4;
    if (t > 10.0) t = 0.0;
    sum += (cached ? arm.forward_kinematics(q, lidar, cache) : arm.forward_kinematics(q, lidar))
               .translation()
               .x();
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_LidarPose)->Arg(0)->Arg(1);

// The states of the default cell's weld plan (at the part's true pose), as the replay steps through them.
const std::vector<JointVector>& default_plan_states() {
  static const std::vector<JointVector> qs = [] {
    DefaultCell& c = cell();
    PlanSetting setting;
    setting.collision = CollisionChecker(c.world);
    const WeldPlan plan = plan_welds(c.part, c.layout.T_base_part, c.robot, setting);
    std::vector<JointVector> out;
    for (const PlanSample& p : plan.samples) out.push_back(p.q);
    return out;
  }();
  return qs;
}

// The default cell's model as the replay and the collision checker have it: the part out of MuJoCo's contacts
// (its exact mesh is checked apart).
ModelPtr model_without_part(const DefaultCell& c) {
  ModelPtr model(mj_copyModel(nullptr, c.world.model()));
  for (int g = 0; g < model->ngeom; ++g)
    if (c.world.geom_label(g) == Label::kPart) model->geom_contype[g] = model->geom_conaffinity[g] = 0;
  return model;
}

// MuJoCo's contacts of the default cell's arm (its links' cylinders and boxes against each other, the table,
// clamps and clutter) at the states of its weld plan: its convex collider for every pair whose bounding
// spheres meet (0) against the exact early-out in front of it (1). Each state's kinematics included; the part
// left out, as the replay leaves it out.
void BM_CellContacts(benchmark::State& state) {
  DefaultCell& c = cell();
  ModelPtr model = model_without_part(c);
  mjModel* m = model.get();
  DataPtr d(mj_makeData(m));
  const std::vector<JointVector>& qs = default_plan_states();
  if (qs.empty()) {
    state.SkipWithError("the default cell's plan has no samples");
    return;
  }
  enable_contact_prefilter(state.range(0) != 0);
  size_t i = 0;
  long contacts = 0;
  for (auto _ : state) {
    c.world.set_joints(m, d.get(), qs[i++ % qs.size()]);
    mj_collision(m, d.get());
    contacts += d->ncon;
  }
  enable_contact_prefilter(true);
  state.counters["contacts_per_state"] =
      static_cast<double>(contacts) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_CellContacts)->Arg(0)->Arg(1);

// The same states as the collision checker asks them: the arm's contact screen first, mj_collision only
// where it finds a contact (compare BM_CellContacts/1, the early-out in).
void BM_ArmContactScreen(benchmark::State& state) {
  DefaultCell& c = cell();
  ModelPtr model = model_without_part(c);
  mjModel* m = model.get();
  DataPtr d(mj_makeData(m));
  const ArmContactScreen screen(m, c.world.geom_labels());
  const std::vector<JointVector>& qs = default_plan_states();
  size_t i = 0;
  long touching = 0;
  for (auto _ : state) {
    c.world.set_joints(m, d.get(), qs[i++ % qs.size()]);
    if (!screen.clear(m, d.get())) {
      mj_collision(m, d.get());
      ++touching;
    }
  }
  state.counters["pairs"] = static_cast<double>(screen.pairs());
  state.counters["touching_per_state"] =
      static_cast<double>(touching) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_ArmContactScreen);

}  // namespace
}  // namespace weldtwin
