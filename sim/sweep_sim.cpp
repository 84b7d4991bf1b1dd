#include "sim/sweep_sim.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

#include "core/knot_poses.hpp"
#include "core/parallel_for.hpp"
#include "sim/embree_scene.hpp"

namespace weldtwin {
namespace {

struct TurnWork {
  const MujocoWorld& world;
  const SweepProgram& program;
  const LidarSetting& lidar;
  const SweepOptions& options;
  const RobotModel& arm;               ///< the arm the world was composed with
  int lidar_link;                      ///< its LiDAR link
  const std::vector<int>& body_links;  ///< the arm's link of each moving body of the scene
  const EmbreeScene& scene;
  SweepResult& out;
  int samples_per_turn;
  const FixedRay* fixed;  ///< the rays and their hits on the shared geometry; the scene: the layout's only
  FixedRay* record;       ///< cast_fixed_rays: where the rays and their hits go
};

// One worker's state: its own chain caches and Embree view, and the slice of the arm's geometry it last
// posed (kept from one turn to the next it casts).
struct TurnCaster {
  explicit TurnCaster(const TurnWork& work)
      : w(work),
        body_caches(w.body_links.size()),
        body_poses(w.body_links.size()),
        view(w.scene.make_view()),
        step(2.0 * kPi / w.samples_per_turn),
        exact(static_cast<size_t>(w.samples_per_turn)),
        beam(static_cast<size_t>(w.samples_per_turn)) {
    // Beam directions in the scan plane, one per sample slot of a turn.
    for (int k = 0; k < w.samples_per_turn; ++k) {
      const double a = static_cast<double>(static_cast<float>(k * step));
      beam[static_cast<size_t>(k)] = Vec3(std::cos(a), std::sin(a), 0.0);
    }
  }

  void cast(size_t turn);

  const TurnWork& w;
  RobotModel::ChainCache chain_cache;
  std::vector<RobotModel::ChainCache> body_caches;
  std::vector<Iso3> body_poses;
  EmbreeScene::View view;
  long current_slice = -1;
  Iso3 slice_end = Iso3::Identity();  // the sensor at the end of the current slice
  double step;
  std::vector<double> exact;
  std::vector<Vec3> beam;
};

// Casts one turn's rays and fills its samples.
void TurnCaster::cast(size_t turn) {
  const LidarTurn& lt = w.out.log.turns[turn];
  LidarErrorModel errors(w.lidar, turn);
  // The sensor is posed exactly at every `sensor_knot_samples`-th sample and interpolated linearly in
  // between: over a few milliseconds the arm's motion is a straight line to far under a micrometre.
  const size_t knot_step = static_cast<size_t>(std::max(1, w.options.sensor_knot_samples));
  auto exact_pose = [&](size_t sample) {
    return w.arm.forward_kinematics(w.program.q(static_cast<double>(sample) / w.lidar.sample_rate_hz),
                                    w.lidar_link, chain_cache);
  };
  // Sample times are i / rate: the index is the time in sample periods, and every knot is near enough.
  KnotPoses poses(
      w.out.log.samples.size(), knot_step, std::numeric_limits<double>::infinity(),
      [&](size_t sample, Iso3& T) {
        T = exact_pose(sample);
        return true;
      },
      [](size_t sample) { return static_cast<double>(sample); });
  for (uint32_t k = 0; k < lt.count; ++k) {
    const size_t i = lt.first + k;
    LidarSample& s = w.out.log.samples[i];
    // Sample times are integer multiples of the sample period, as the joint log's are.
    s.t_s = static_cast<double>(i) / w.lidar.sample_rate_hz;  // the double nearest i / rate
    s.angle_rad = static_cast<float>(k * step);
    // The first hit: its distance (< 0: none), the cosine of its incidence, and the geom.
    double distance = -1.0, cos_incidence = 1.0;
    int geom = -1;
    if (w.fixed) {
      // The shared geometry's hit is known: the layout's geoms are cast against up to it.
      const FixedRay& f = w.fixed[i];
      const RayHit hit =
          view.cast(f.origin, f.dir, 1e-6, f.distance_m >= 0.0 ? f.distance_m : w.lidar.max_range_m * 1.05);
      if (hit.hit() && (f.distance_m < 0.0 || hit.distance_m < f.distance_m)) {
        distance = hit.distance_m, geom = hit.geom;
        cos_incidence = std::clamp(-hit.normal.dot(f.dir), 0.0, 1.0);
      } else {
        distance = f.distance_m, geom = f.geom, cos_incidence = f.cos_incidence;
      }
    } else {
      const long slice = static_cast<long>(std::floor(s.t_s / w.options.slice_s));
      if (slice != current_slice) {
        // The arm's geometry, posed at the start of the slice.
        const JointVector q_slice = w.program.q(static_cast<double>(slice) * w.options.slice_s);
        for (size_t b = 0; b < body_poses.size(); ++b)
          body_poses[b] = w.arm.forward_kinematics(q_slice, w.body_links[b], body_caches[b]);
        view.update(body_poses);
        // All of the slice's rays lie in scan planes between those at its start and end.
        if (w.options.cull_by_scan_plane) {
          const double t0 = static_cast<double>(slice) * w.options.slice_s;
          // The sensor at the slice's start: the last slice's end when they follow each other.
          const Iso3 A =
              slice == current_slice + 1 ? slice_end : w.arm.forward_kinematics(q_slice, w.lidar_link);
          const Iso3 B = w.arm.forward_kinematics(w.program.q(t0 + w.options.slice_s), w.lidar_link);
          slice_end = B;
          const double tilt = Eigen::AngleAxisd(A.linear().transpose() * B.linear()).angle();
          view.restrict_to_plane(A.translation(), A.linear().col(2),
                                 (B.translation() - A.translation()).norm(), 1.5 * tilt);
        }
        current_slice = slice;
      }
      Iso3 T;
      poses.pose(i, T);
      if (w.options.record_sensor_poses) w.out.T_base_lidar[i] = T;
      // The ray leaves the scan centre in the scan plane, counter-clockwise about +z from +x.
      const Vec3 dir = (T.linear() * beam[k]).normalized();
      const RayHit hit = view.cast(T.translation(), dir, 1e-6, w.lidar.max_range_m * 1.05);
      if (hit.hit()) {
        distance = hit.distance_m, geom = hit.geom;
        cos_incidence = std::clamp(-hit.normal.dot(dir), 0.0, 1.0);
      }
      if (w.record) w.record[i] = FixedRay{T.translation(), dir, distance, cos_incidence, geom};
    }
    exact[k] = distance >= 0.0 ? distance : 0.0;
    double r = 0.0;
    if (distance >= 0.0) r = errors.measure(distance, cos_incidence);
    s.range_m = static_cast<float>(r);
    s.quality = r > 0.0 ? LidarErrorModel::quality(r, cos_incidence) : 0;
    w.out.geoms[i] = r > 0.0 ? geom : -1;
    w.out.labels[i] = r > 0.0 ? w.world.geom_label(geom) : Label::kNone;
  }
  // Mixed pixels: where neighbours straddle a depth edge, the beam footprint covers both surfaces and the
  // A2 reports a range in between.
  if (w.lidar.mixed_pixels) {
    for (uint32_t k = 0; k + 1 < lt.count; ++k) {
      const size_t i = lt.first + k;
      LidarSample& s = w.out.log.samples[i];
      const double r0 = exact[k], r1 = exact[k + 1];
      if (s.range_m <= 0.0f || r1 <= 0.0 || std::abs(r1 - r0) < w.lidar.mixed_pixel_jump_m) continue;
      if (errors.uniform() >= w.lidar.mixed_pixel_probability) continue;
      double blend = r0 + errors.uniform() * (r1 - r0);
      if (w.lidar.quantize) blend = std::round(blend / w.lidar.resolution_m) * w.lidar.resolution_m;
      s.range_m = static_cast<float>(blend);
      w.out.geoms[i] = -1;
      w.out.labels[i] = Label::kOther;
    }
  }
}

double sweep_duration(const SweepProgram& program, const SweepOptions& options) {
  return options.max_duration_s > 0.0 ? std::min(options.max_duration_s, program.duration_s())
                                      : program.duration_s();
}

size_t sweep_turns(const SweepProgram& program, const LidarSetting& lidar, const SweepOptions& options) {
  return static_cast<size_t>(std::floor(sweep_duration(program, options) * lidar.turn_rate_hz));
}

SweepResult sweep(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                  const LidarSetting& lidar, const SweepOptions& options, FixedRay* record) {
  const auto wall_start = std::chrono::steady_clock::now();
  SweepResult out;
  const double duration = sweep_duration(program, options);
  const int per_turn = lidar.samples_per_turn();
  const size_t turns = sweep_turns(program, lidar, options);

  ScanLog& log = out.log;
  log.source = "sim";
  log.robot = robot.name();
  log.lidar_frame = options.lidar_link;
  log.joint_names = robot.joint_names();
  log.turns.resize(turns);
  for (size_t t = 0; t < turns; ++t) {
    log.turns[t].first = static_cast<uint32_t>(t * static_cast<size_t>(per_turn));
    log.turns[t].count = static_cast<uint32_t>(per_turn);
    log.turns[t].t_start_s = static_cast<double>(log.turns[t].first) / lidar.sample_rate_hz;
  }
  const size_t n = turns * static_cast<size_t>(per_turn);
  log.samples.resize(n);
  out.labels.assign(n, Label::kNone);
  out.geoms.assign(n, -1);
  if (options.record_sensor_poses) out.T_base_lidar.resize(n);

  // Joint states as the controller would log them, at a fixed rate over the whole sweep.
  const double log_hz = options.joint_log_hz > 0.0 ? options.joint_log_hz : program.joint_log_hz();
  const size_t states = static_cast<size_t>(std::floor(duration * log_hz)) + 1;
  log.joints.resize(states);
  for (size_t k = 0; k < states; ++k) {
    log.joints[k].t_s = static_cast<double>(k) / log_hz;
    log.joints[k].q = program.q(log.joints[k].t_s);
  }

  const RobotModel& arm = world.robot();
  const int lidar_link = arm.require_link(options.lidar_link);
  const FixedRay* fixed = record ? nullptr : options.fixed_rays;
  if (fixed && options.fixed_ray_count != n)
    throw std::invalid_argument("simulate_sweep: fixed_rays are for " +
                                std::to_string(options.fixed_ray_count) + " samples, this sweep has " +
                                std::to_string(n));
  if (fixed && options.record_sensor_poses)
    throw std::invalid_argument("simulate_sweep: fixed_rays do not give the sensor poses");
  // With fixed rays, the layout's geoms only; to record them, the rest only; else all.
  std::function<bool(int)> include;
  if (fixed) include = [&world](int g) { return world.placed_by_layout(g); };
  if (record) include = [&world](int g) { return !world.placed_by_layout(g); };
  const EmbreeScene scene(world.model(), world.data(), include);
  std::vector<int> body_links;
  for (int b : scene.moving_bodies()) {
    body_links.push_back(world.robot_link(b));
    if (body_links.back() < 0) throw std::logic_error("simulate_sweep: a moving body that is not the arm's");
  }
  const TurnWork work{world,      program, lidar, options,  arm,   lidar_link,
                      body_links, scene,   out,   per_turn, fixed, record};
  parallel_for_with(
      turns, std::max(0, options.threads), [&] { return TurnCaster(work); },
      [](TurnCaster& caster, size_t turn) { caster.cast(turn); }, options.progress);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return out;
}

}  // namespace

SweepResult simulate_sweep(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                           const LidarSetting& lidar, const SweepOptions& options) {
  return sweep(world, robot, program, lidar, options, nullptr);
}

size_t sweep_sample_count(const SweepProgram& program, const LidarSetting& lidar,
                          const SweepOptions& options) {
  return sweep_turns(program, lidar, options) * static_cast<size_t>(lidar.samples_per_turn());
}

void cast_fixed_rays(const MujocoWorld& world, const RobotModel& robot, const SweepProgram& program,
                     const LidarSetting& lidar, const SweepOptions& options, FixedRay* out) {
  SweepOptions o = options;
  o.record_sensor_poses = false;
  sweep(world, robot, program, lidar, o, out);
}

}  // namespace weldtwin
