#include "app/bench_command.hpp"

#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <thread>
#include <utility>

#include "app/json_file.hpp"
#include "app/mount_file.hpp"
#include "app/plan_file.hpp"
#include "app/pose_file.hpp"
#include "core/cell_spec.hpp"
#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/scenes.hpp"
#include "perception/localizer.hpp"
#include "perception/mount_calibration.hpp"
#include "perception/paper_localizer.hpp"
#include "perception/pose_error.hpp"
#include "perception/scan_assembly.hpp"
#include "pipeline/outcome.hpp"
#include "pipeline/weld_pipeline.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/placement_guidance.hpp"
#include "sim/replay.hpp"
#include "sim/sweep_sim.hpp"
#include "sim/twin_calibration.hpp"

namespace weldtwin {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The cell, with another robot file's arm and tooling and another placement area when they are given.
CellSpec adapted(CellSpec cell, const BenchCommand& cmd) {
  if (!cmd.robot.empty()) cell.use_robot_file(cmd.robot);
  if (cmd.placement) cell.placement.area = *cmd.placement;
  return cell;
}

// One part's cell, loaded once by the parent (children inherit it).
struct BenchCell : TwinCell {
  /// The sweep's rays and their hits on what all layouts of the cell share (cast_shared_rays); null: none.
  const FixedRay* fixed_rays = nullptr;
  size_t fixed_ray_count = 0;
  /// The part made ready for our localizer, by the first trial of a worker that localizes it (not in the
  /// parent: its Embree device is not to cross a fork); every answer is the one the mesh itself gives.
  mutable std::shared_ptr<const PreparedPart> prepared;

  const PreparedPart& prepared_part(const LocalizeSetting& setting) const {
    if (!prepared) prepared = std::make_shared<const PreparedPart>(mesh, setting);
    return *prepared;
  }

  BenchCell(const std::string& file, const BenchCommand& cmd)
      : TwinCell(adapted(CellSpec::load(file), cmd), cmd.sweep, cmd.rescans) {}
};

// Everything a trial draws, from (seed, index) alone.
struct Draw {
  uint64_t index = 0, trial_seed = 0;
  size_t cell = 0;
  uint64_t layout_seed = 0, lidar_seed = 0, encoder_seed = 0;
  CellLayout layout;
  Vec3 mount_xyz_m = Vec3::Zero(), mount_rpy_rad = Vec3::Zero();
};

uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// A pose counts as a success when turned by at most this (and its seams within the weld tolerance).
constexpr double kMaxRotationRad = deg2rad(0.5);

// Numbers in the lines: rounded, so that the files are short and read well.
double rounded(double v, double unit) {
  const double per = std::round(1.0 / unit);  // a power of ten: the quotient is the nearest double
  return std::round(v * per) / per;
}

// Fills `d` as far as it gets (a layout that cannot be drawn throws, with the rest of the draw known).
void draw_trial(const BenchCommand& cmd, const std::vector<BenchCell>& cells, uint64_t index, Draw& d) {
  d.index = index;
  d.trial_seed = splitmix64(splitmix64(cmd.seed) ^ index);
  std::mt19937_64 rng(d.trial_seed);
  d.cell = static_cast<size_t>(rng() % cells.size());
  d.layout_seed = rng() >> 1;
  d.lidar_seed = rng() >> 1;
  d.encoder_seed = rng() >> 1;
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int k = 0; k < 3; ++k) d.mount_xyz_m[k] = cmd.mount_error_m * normal(rng);
  for (int k = 0; k < 3; ++k) d.mount_rpy_rad[k] = cmd.mount_error_rad * normal(rng);
  const BenchCell& c = cells[d.cell];
  d.layout = make_layout(c.cell, c.part, d.layout_seed);
}

json draw_json(const Draw& d, const std::vector<BenchCell>& cells, const BenchCommand& cmd) {
  const BenchCell& c = cells[d.cell];
  const Iso3& T = d.layout.T_base_part;
  json j;
  j["cell"] = c.cell.name;
  j["part"] = c.part.name;
  j["x_m"] = rounded(T.translation().x(), 1e-6);
  j["y_m"] = rounded(T.translation().y(), 1e-6);
  double yaw = rad2deg(std::atan2(T.linear()(1, 0), T.linear()(0, 0)));
  if (yaw < 0) yaw += 360.0;
  j["yaw_deg"] = rounded(yaw, 1e-4);
  j["clamps"] = d.layout.clamps.size();
  j["clutter"] = d.layout.clutter.size();
  j["layout_seed"] = d.layout_seed;
  j["lidar_seed"] = d.lidar_seed;
  if (!cmd.sweep.empty()) j["sweep"] = std::filesystem::path(cmd.sweep).stem().string();
  if (!cmd.rescans.empty()) {
    std::string names;  // their stems, '+' between
    for (const std::string& r : cmd.rescans)
      names += (names.empty() ? "" : "+") + std::filesystem::path(r).stem().string();
    j["rescan"] = names;
  }
  if (!cmd.robot.empty()) j["robot"] = std::filesystem::path(cmd.robot).stem().string();
  if (cmd.placement) j["placement"] = placement_area_name(*cmd.placement);
  if (!cmd.viewpoints) j["viewpoints"] = false;
  if (cmd.mount_error_m > 0 || cmd.mount_error_rad > 0) {
    j["mount_error_mm"] = {rounded(1e3 * d.mount_xyz_m.x(), 1e-4), rounded(1e3 * d.mount_xyz_m.y(), 1e-4),
                           rounded(1e3 * d.mount_xyz_m.z(), 1e-4)};
    j["mount_error_deg"] = {rounded(rad2deg(d.mount_rpy_rad.x()), 1e-5),
                            rounded(rad2deg(d.mount_rpy_rad.y()), 1e-5),
                            rounded(rad2deg(d.mount_rpy_rad.z()), 1e-5)};
  }
  if (cmd.encoder_noise_rad > 0) j["encoder_noise_rad"] = cmd.encoder_noise_rad;
  return j;
}

json pose_json(const PoseEstimate& p, const PoseError& e, double weld_tolerance_m) {
  json j;
  j["found"] = p.found;
  if (!p.found) j["reason"] = p.reason;
  j["seam_max_mm"] = rounded(1e3 * e.seam_max_m, 1e-4);
  j["seam_mean_mm"] = rounded(1e3 * e.seam_mean_m, 1e-4);
  j["rotation_deg"] = rounded(rad2deg(e.rotation_rad), 1e-5);
  j["fitness"] = rounded(p.fitness, 1e-4);
  j["success"] = p.found && e.seam_max_m <= weld_tolerance_m && e.rotation_rad <= kMaxRotationRad;
  return j;
}

void set_verdict(json& j, const std::vector<Failure>& failures) {
  j["verdict"] = failures.empty() ? "pass" : "fail";
  if (!failures.empty()) {
    j["cause"] = failures.front().text();
    j["cause_kind"] = failure_kind_name(failures.front().kind);
  }
}

// Every trial of a cell sweeps the same arm over the same table: the rays and what they meet of the
// environment and the arm are cast once per cell, each cell in a child process (Embree's thread pool stays
// out of the process that forks the workers), into shared memory the workers read; a trial then
// casts only against its own part, clamps and clutter. Cells whose cast fails are swept whole by each trial.
// (A child reads the shared pages in 64 KB at a fault; a private copy in the parent, whose page tables a
// fork would copy, was no faster.)
// Returns the mappings, to be unmapped at the end.
std::vector<std::pair<void*, size_t>> cast_shared_rays(std::vector<BenchCell>& cells) {
  std::vector<std::pair<void*, size_t>> maps;
  std::vector<pid_t> pids;
  std::vector<size_t> counts;
  std::fflush(nullptr);
  for (BenchCell& c : cells) {
    LidarSetting lidar;
    lidar.apply(c.cell.lidar_overrides, c.cell.source);
    SweepOptions options;
    options.threads = 1;
    const size_t n = sweep_sample_count(c.program, lidar, options);
    counts.push_back(n);
    const size_t bytes = std::max<size_t>(1, n * sizeof(FixedRay));
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    maps.emplace_back(p == MAP_FAILED ? nullptr : p, bytes);
    const pid_t pid = p == MAP_FAILED ? -1 : fork();
    if (pid == 0) {
      try {
        const MujocoWorld world(c.cell, c.part, c.robot, make_layout(c.cell, c.part, std::nullopt));
        cast_fixed_rays(world, c.robot, c.program, lidar, options, static_cast<FixedRay*>(p));
      } catch (const std::exception&) {
        _exit(1);
      }
      _exit(0);
    }
    pids.push_back(pid);
  }
  for (size_t k = 0; k < cells.size(); ++k) {
    int status = 0;
    const bool ok = pids[k] > 0 && waitpid(pids[k], &status, 0) == pids[k] && WIFEXITED(status) &&
                    WEXITSTATUS(status) == 0;
    if (!ok || maps[k].first == nullptr) continue;
    cells[k].fixed_rays = static_cast<const FixedRay*>(maps[k].first);
    cells[k].fixed_ray_count = counts[k];
  }
  return maps;
}

// One trial, start to end, in this process. Timings go under "seconds" (the only part that differs between
// runs of the same seed).
json run_trial(const BenchCommand& cmd, const BenchCell& c, const Draw& d,
               const CalibrationCell* calibration) {
  json j;
  j["index"] = d.index;
  j["seed"] = cmd.seed;
  json seconds;
  auto t = Clock::now();
  auto lap = [&](const char* stage) {
    const auto now = Clock::now();
    seconds[stage] = rounded(std::chrono::duration<double>(now - t).count(), 1e-4);
    t = now;
  };
  const auto t0 = t;

  // The cell as it really is: with the mount error the sweep sees through; the nominal robot assembles it.
  const std::string lidar_link = SweepOptions().lidar_link;
  const bool mount_error = !d.mount_xyz_m.isZero() || !d.mount_rpy_rad.isZero();
  const Vec3 mm = 1e3 * d.mount_xyz_m, deg = d.mount_rpy_rad * 180.0 / kPi;
  const Iso3 delta = mount_offset({mm.x(), mm.y(), mm.z()}, {deg.x(), deg.y(), deg.z()});
  const TwinScene twin(c, d.layout, delta);  // no error drawn: the identity
  lap("world");
  LidarSetting lidar;
  lidar.apply(c.cell.lidar_overrides, c.cell.source);
  lidar.seed = d.lidar_seed;
  SweepOptions options;
  options.threads = 1;  // trials run side by side instead
  if (!mount_error) options.fixed_rays = c.fixed_rays, options.fixed_ray_count = c.fixed_ray_count;
  SweepResult sweep = simulate_sweep(twin.world, twin.real_robot, c.program, lidar, options);
  lap("sweep");
  // Joint encoder noise on the recorded joint states, drawn from `seed`.
  auto encoder_noise = [&](ScanLog& log, uint64_t seed) {
    if (cmd.encoder_noise_rad <= 0) return;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, cmd.encoder_noise_rad);
    for (JointState& s : log.joints)
      for (int k = 0; k < s.q.size(); ++k) s.q[k] += noise(rng);
  };
  encoder_noise(sweep.log, d.encoder_seed);
  // With --calibrate, the mount is first found from a sweep of the calibration cell through the same
  // (wrong) mount, and the scan assembled with it; otherwise with the URDF's.
  RobotModel assembly_robot = c.robot;
  if (calibration) {
    const MountCalibration cal =
        calibrate_in_twin(*calibration, twin.real_robot, c.robot, d.lidar_seed + 1, options);
    assembly_robot = c.robot.with_mount_offset(lidar_link, cal.delta);
    j["calibration"] = {
        {"translation_error_mm", rounded(1e3 * (cal.delta.translation() - delta.translation()).norm(), 1e-4)},
        {"rotation_error_deg",
         rounded(rad2deg(Eigen::AngleAxisd(cal.delta.linear().transpose() * delta.linear()).angle()), 1e-5)}};
    lap("calibrate");
  }
  AssembledCloud cloud = assemble_scan(sweep.log, assembly_robot);
  j["scan_points"] = cloud.points_base.size();
  lap("assemble");

  WeldPipelineSetting setting;
  setting.localize.threads = 1;
  setting.viewpoints = cmd.viewpoints;
  setting.plan = cmd.replay;
  setting.planning.search_weld_window = cmd.weld_window;
  setting.replay.threads = 1;
  setting.replay.timestep_s = cmd.replay_step_s;
  WeldJob job;
  job.cell = &c;
  job.prepared = &c.prepared_part(setting.localize);
  job.twin = &twin;
  job.T_base_part_twin = d.layout.T_base_part;
  job.truth_known = true;
  WeldPipelineHooks hooks;
  hooks.stage_done = [&](PipelineStage stage, const WeldPipelineResult& r) {
    switch (stage) {
      case PipelineStage::kFind:
        j["ours"] = pose_json(r.pose, *r.pose_error, c.part.weld_tolerance_m);
        lap("ours");
        if (cmd.paper) {  // the paper's pipeline on the same scan, beside ours
          const PoseEstimate paper = localize_paper(cloud.points_base, c.mesh);  // every sweep's points
          j["paper"] =
              pose_json(paper, pose_error(c.part, paper.T_base_part, d.layout.T_base_part, c.symmetry),
                        c.part.weld_tolerance_m);
          lap("paper");
        }
        break;
      case PipelineStage::kPlan: {
        const WeldPlan& plan = *r.plan;
        json p;
        p["ok"] = plan.ok();
        if (!plan.ok()) p["problem"] = plan.problems.front();
        p["seams"] = plan.seams.size();
        p["duration_s"] = rounded(plan.duration_s(), 1e-4);
        j["plan"] = p;
        lap("plan");
        break;
      }
      case PipelineStage::kReplay: {
        const ReplayResult& rr = *r.replay;
        json rj;
        rj["passed"] = rr.passed();
        rj["max_seam_error_mm"] = rounded(1e3 * rr.max_seam_error_m, 1e-4);
        rj["contacts"] = rr.contacts.size();
        rj["min_clearance_mm"] = rounded(1e3 * rr.min_clearance_m, 1e-3);
        if (!rr.passed()) rj["failure"] = rr.failures.front();
        j["replay"] = rj;
        lap("replay");
        break;
      }
    }
  };
  WeldPipelineResult result = weld_pipeline(cloud.points_base, cloud.viewpoints_base, job, setting, hooks);
  // The cell's rescans while the sweeps so far leave the part not found, or found short of the 99 % bar
  // (TwinCell::sweep_again_because): each swept too (their rays are not the shared ones), and the part
  // sought in all of them, as weldtwin run does.
  for (size_t k = 0; c.sweeps_again(result.pose, k); ++k) {
    lidar.seed = rescan_lidar_seed(d.lidar_seed, k);
    options.fixed_rays = nullptr;
    options.fixed_ray_count = 0;
    SweepResult again = simulate_sweep(twin.world, twin.real_robot, c.rescans[k], lidar, options);
    encoder_noise(again.log, rescan_lidar_seed(d.encoder_seed, k));
    const AssembledCloud more = assemble_scan(again.log, assembly_robot);
    cloud.points_base.insert(cloud.points_base.end(), more.points_base.begin(), more.points_base.end());
    cloud.viewpoints_base.insert(cloud.viewpoints_base.end(), more.viewpoints_base.begin(),
                                 more.viewpoints_base.end());
    j["rescanned"] = true;
    j["rescans"] = k + 1;
    j["scan_points"] = cloud.points_base.size();
    lap("rescan");
    result = weld_pipeline(cloud.points_base, cloud.viewpoints_base, job, setting, hooks);
  }
  const PoseEstimate& ours = result.pose;
  j["seams_under_1mm"] = result.seams_within_tolerance;
  set_verdict(j, result.failures);
  if (cmd.guidance && !result.passed() && cmd.replay && ours.found &&
      result.pose_error->seam_max_m <= c.part.weld_tolerance_m) {
    // Where the operator would be told to put it, and the trial again with the part there (the same
    // clamp sites, the clutter where it was, the same LiDAR noise).
    GuidanceSetting guide;
    guide.plan.search_weld_window = cmd.weld_window;
    guide.replay.threads = 1;
    guide.replay.timestep_s = cmd.replay_step_s;
    CellLayout now = d.layout;
    now.T_base_part = ours.T_base_part;
    const PlacementSuggestion s = suggest_placement(c.cell, c.part, c.robot, c.mesh, now, c.symmetry, guide);
    json g = {{"found", s.found},
              {"screened", s.screened},
              {"planned_and_replayed", s.verified},
              {"seconds", rounded(s.seconds, 1e-3)}};
    if (s.found) {
      g["instruction"] = s.instruction;
      g["move_mm"] = rounded(1e3 * s.move_m, 1e-3);
      g["turn_deg"] = rounded(rad2deg(s.turn_rad), 1e-3);
      // Put down as an operator would: within the guidance's tolerance of where asked (uniform, drawn from
      // the trial's seed), or where asked when the part and its clamps would not fit so.
      std::mt19937_64 rng(d.trial_seed ^ 0x67756964616e6365ull);
      std::uniform_real_distribution<double> u(-1.0, 1.0);
      const Vec3 off(guide.placement_tolerance_m * u(rng), guide.placement_tolerance_m * u(rng), 0.0);
      const double turn = guide.placement_tolerance_rad * u(rng);
      const CellSpec laid_out = cell_as_laid_out(c.cell, d.layout);
      Iso3 put = s.T_base_part;
      put.translation() += off;
      put.linear() = Eigen::AngleAxisd(turn, Vec3::UnitZ()).toRotationMatrix() * put.linear();
      Draw moved = d;
      moved.layout = layout_at(laid_out, c.part, put);
      if (!layout_problem(laid_out, c.part, moved.layout).empty()) {
        moved.layout = layout_at(laid_out, c.part, s.T_base_part);
        put = s.T_base_part;
      }
      g["put_off_mm"] = rounded(1e3 * (put.translation() - s.T_base_part.translation()).norm(), 1e-3);
      g["put_turned_deg"] = rounded(
          rad2deg(Eigen::AngleAxisd(put.linear() * s.T_base_part.linear().transpose()).angle()), 1e-3);
      BenchCommand again = cmd;
      again.guidance = false;
      again.paper = false;
      again.keep_failed.clear();
      const json tried = run_trial(again, c, moved, calibration);
      g["tried"] = {{"verdict", tried.value("verdict", "fail")},
                    {"seams_under_1mm", tried.value("seams_under_1mm", false)}};
      if (tried.contains("cause")) g["tried"]["cause"] = tried["cause"];
    } else {
      g["reason"] = s.reason;
    }
    j["guidance"] = g;
    lap("guidance");
  }
  if (!result.passed() && !cmd.keep_failed.empty()) {
    // What it takes to look again: `weldtwin replay DIR/plan.json CELL --seed <draw.layout_seed>` shows the
    // replay with pictures; `weldtwin localize --scan DIR/scan.pcd` the localization.
    const std::string dir = cmd.keep_failed + "/trial-" + std::to_string(d.index);
    std::filesystem::create_directories(dir);
    write_pcd(dir + "/scan.pcd", cloud.points_base, false, &cloud.viewpoints_base);
    write_json_file(dir + "/pose_ours.json", pose_to_json(ours));
    write_json_file(dir + "/pose_true.json", true_pose_json(d.layout.T_base_part));
    if (result.plan && !result.plan->samples.empty())
      write_json_file(dir + "/plan.json", plan_to_json(*result.plan, c.part, c.robot, result.plan_setting),
                      -1);
    j["kept"] = dir;
  }
  seconds["total"] = rounded(std::chrono::duration<double>(Clock::now() - t0).count(), 1e-4);
  j["seconds"] = seconds;
  return j;
}

// The line of a trial whose child did not give one.
json failed_trial(const BenchCommand& cmd, const std::vector<BenchCell>& cells, const Draw& d,
                  const Failure& cause, double seconds) {
  json j;
  j["index"] = d.index;
  j["seed"] = cmd.seed;
  j["draw"] = draw_json(d, cells, cmd);
  j["seams_under_1mm"] = false;
  set_verdict(j, {cause});
  j["seconds"] = {{"total", rounded(seconds, 1e-4)}};
  return j;
}

void inject_fault(const std::vector<std::string>& faults, uint64_t index) {
  for (const std::string& fault : faults) {
    const size_t colon = fault.find(':');
    if (colon == std::string::npos || std::stoull(fault.substr(0, colon)) != index) continue;
    const std::string what = fault.substr(colon + 1);
    if (what == "crash") std::raise(SIGSEGV);
    if (what == "hang")
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
    if (what == "throw") throw std::runtime_error("fault injected for a test");
  }
}

std::string duration_text(double s) {
  char b[32];
  if (s >= 3600)
    std::snprintf(b, sizeof b, "%dh%02dm", static_cast<int>(s / 3600), static_cast<int>(s / 60) % 60);
  else
    std::snprintf(b, sizeof b, "%dm%02ds", static_cast<int>(s / 60), static_cast<int>(s) % 60);
  return b;
}

// A trial, drawn from (seed, index) and run in this process; what it throws is its failure.
json trial_line(const BenchCommand& cmd, const std::vector<BenchCell>& cells, uint64_t index,
                const CalibrationCell* calibration) {
  Draw d;
  try {
    draw_trial(cmd, cells, index, d);
  } catch (const std::exception& e) {
    return failed_trial(cmd, cells, d,
                        {FailureKind::kError, std::string("the cell could not be drawn: ") + e.what()}, 0.0);
  }
  try {
    inject_fault(cmd.faults, index);
    json line = run_trial(cmd, cells[d.cell], d, calibration);
    line["draw"] = draw_json(d, cells, cmd);
    return line;
  } catch (const std::exception& e) {
    return failed_trial(cmd, cells, d, {FailureKind::kError, e.what()}, 0.0);
  }
}

bool write_all(int fd, const std::string& text) {
  for (size_t off = 0; off < text.size();) {
    const ssize_t n = write(fd, text.data() + off, text.size() - off);
    if (n <= 0) return false;
    off += static_cast<size_t>(n);
  }
  return true;
}

// A worker: a process forked from the one that loaded the cells, running the trials it is handed (their
// slots, one per line) one after another and answering each with its JSON line. A trial that crashes or hangs
// takes its worker with it, and a new one takes over. Trials after a worker's first run in the memory the
// ones before freed (malloc keeps it: no mmap, no trimming): a process per trial spent about a tenth of
// its time faulting fresh pages in.
struct Worker {
  pid_t pid = -1;
  int to = -1;    ///< slots, one per line
  int from = -1;  ///< the trials' lines
  bool busy = false;
  size_t slot = 0;  ///< the trial it runs: position in this shard's list of trials
  int handed = 0;   ///< trials handed to it so far
  std::string text;
  Clock::time_point start;
};

[[noreturn]] void worker_main(int in, int out, const BenchCommand& cmd, const std::vector<BenchCell>& cells,
                              const std::vector<uint64_t>& indices, const CalibrationCell* calibration) {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
  std::string pending;
  for (;;) {
    size_t nl;
    while ((nl = pending.find('\n')) == std::string::npos) {
      char buf[64];
      const ssize_t n = read(in, buf, sizeof buf);
      if (n <= 0) _exit(0);  // no more trials
      pending.append(buf, static_cast<size_t>(n));
    }
    const size_t slot = std::stoull(pending.substr(0, nl));
    pending.erase(0, nl + 1);
    if (!write_all(out, trial_line(cmd, cells, indices[slot], calibration).dump() + '\n')) _exit(1);
  }
}

}  // namespace

json bench_trial_at(const BenchCommand& cmd, const std::string& cell_file, uint64_t layout_seed,
                    uint64_t lidar_seed) {
  const std::vector<BenchCell> cells{BenchCell(cell_file, cmd)};
  Draw d;
  d.layout_seed = layout_seed;
  d.lidar_seed = lidar_seed;
  d.layout = make_layout(cells[0].cell, cells[0].part, layout_seed);
  json line = run_trial(cmd, cells[0], d, nullptr);
  line["draw"] = draw_json(d, cells, cmd);
  return line;
}

int run_bench(const BenchCommand& cmd_in) {
  BenchCommand cmd = cmd_in;
  if (cmd.trials < 0) throw InputError("--trials must not be negative");
  if (cmd.shards < 1 || cmd.shard < 0 || cmd.shard >= cmd.shards)
    throw InputError("--shard K/N needs 0 <= K < N (got " + std::to_string(cmd.shard) + "/" +
                     std::to_string(cmd.shards) + ")");
  if (cmd.out.empty()) throw InputError("--out: the results file (JSON lines) is needed");
  if (cmd.jobs < 0) throw InputError("--jobs must be at least 1 (or 0: one per core)");
  if (!(cmd.timeout_s > 0.0)) throw InputError("--timeout-s must be a positive number of seconds");
  if (!(cmd.replay_step_s > 0.0) || !std::isfinite(cmd.replay_step_s))
    throw InputError("--replay-step-ms must be a positive number of milliseconds");
  for (const auto& [name, sigma] : {std::pair{"--mount-error-mm", cmd.mount_error_m},
                                    {"--mount-error-deg", cmd.mount_error_rad},
                                    {"--encoder-noise-rad", cmd.encoder_noise_rad}})
    if (!(sigma >= 0.0) || !std::isfinite(sigma))
      throw InputError(std::string(name) + " is a standard deviation: it must not be negative");
  for (const std::string& f : cmd.faults)
    if (f.find(':') == std::string::npos || f.find_first_not_of("0123456789") != f.find(':'))
      throw InputError("--fault: '" + f + "' is not INDEX:crash|hang|throw");
  if (cmd.cells.empty())
    for (const char* name : {"default", "round_on_plate", "tube_tee"})
      cmd.cells.push_back(scene_file(std::string("cells/") + name + ".yaml"));
  if (cmd.jobs <= 0) cmd.jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<BenchCell> cells;
  for (const std::string& f : cmd.cells) cells.emplace_back(f, cmd);
  std::optional<CalibrationCell> calibration;
  if (cmd.calibrate)
    calibration.emplace(adapted(CellSpec::load(scene_file("cells/calibration.yaml")), cmd),
                        cells.front().robot);

  std::vector<uint64_t> indices;
  for (int i = cmd.shard; i < cmd.trials; i += cmd.shards) indices.push_back(static_cast<uint64_t>(i));
  const std::filesystem::path out_path(cmd.out);
  if (out_path.has_parent_path()) std::filesystem::create_directories(out_path.parent_path());
  // --resume: the finished lines of an earlier run of the same benchmark are kept (a cut-off last line is
  // not).
  std::map<uint64_t, std::string> earlier;
  if (cmd.resume && std::filesystem::is_regular_file(cmd.out)) {
    std::ifstream in(cmd.out);
    for (std::string text; std::getline(in, text);) {
      json j;
      try {
        j = json::parse(text);
      } catch (const std::exception&) {
        continue;  // the line a stopped run was writing
      }
      if (j.value("seed", cmd.seed + 1) != cmd.seed)
        throw input_error(cmd.out, "holds trials of another seed: not this benchmark's to resume");
      if (j.contains("index")) earlier[j["index"].get<uint64_t>()] = text;
    }
  }
  std::ofstream out(cmd.out, std::ios::trunc);
  if (!out) throw InputError(cmd.out + ": cannot be written");

  const bool tty = isatty(STDERR_FILENO) && !cmd.quiet;
  if (!cmd.quiet)
    std::fprintf(stderr,
                 "bench: %zu trials (shard %d/%d of %d, seed %llu), %d at once, parts: %zu cells -> %s\n",
                 indices.size(), cmd.shard, cmd.shards, cmd.trials, static_cast<unsigned long long>(cmd.seed),
                 cmd.jobs, cells.size(), cmd.out.c_str());

  std::vector<std::string> lines(indices.size());
  std::vector<bool> done(indices.size(), false);
  size_t written = 0, finished = 0, passed = 0, ours_ok = 0;
  size_t resumed = 0;
  std::deque<size_t> todo;
  for (size_t slot = 0; slot < indices.size(); ++slot) {
    const auto it = earlier.find(indices[slot]);
    if (it == earlier.end()) {
      todo.push_back(slot);
      continue;
    }
    lines[slot] = it->second;
    done[slot] = true;
    ++resumed;
  }
  finished = resumed;
  while (written < lines.size() && done[written]) out << lines[written++] << '\n';
  out.flush();
  if (!out) throw InputError(cmd.out + ": cannot be written (is the disk full?)");
  bool write_failed = false;  // a trial's line could not be saved: the run stops, the lines before it kept
  if (resumed > 0 && !cmd.quiet)
    std::fprintf(stderr, "bench: %zu trials kept from %s\n", resumed, cmd.out.c_str());
  const auto t_start = Clock::now();
  const std::vector<std::pair<void*, size_t>> shared_rays =
      todo.empty() ? std::vector<std::pair<void*, size_t>>() : cast_shared_rays(cells);
  std::fflush(nullptr);  // children inherit no half-written buffers

  auto finish = [&](size_t slot, const json& line) {
    lines[slot] = line.dump();
    done[slot] = true;
    ++finished;
    if (line.value("verdict", "") == "pass") ++passed;
    if (line.value("seams_under_1mm", false)) ++ours_ok;  // the target's measure, as bench-report counts it
    while (written < lines.size() && done[written]) {
      out << lines[written] << '\n';
      lines[written].clear();
      ++written;
    }
    out.flush();
    write_failed = write_failed || !out;
    if (cmd.quiet) return;
    const double elapsed = std::chrono::duration<double>(Clock::now() - t_start).count();
    const double eta =
        elapsed / static_cast<double>(finished - resumed) * static_cast<double>(indices.size() - finished);
    if (tty) {
      const int width = 30, filled = static_cast<int>(width * finished / indices.size());
      std::fprintf(stderr, "\rbench [%s%s] %zu/%zu  ours: seams within 1 mm %zu, welded %zu  %s, ETA %s   ",
                   std::string(static_cast<size_t>(filled), '#').c_str(),
                   std::string(static_cast<size_t>(width - filled), '.').c_str(), finished, indices.size(),
                   ours_ok, passed, duration_text(elapsed).c_str(), duration_text(eta).c_str());
    } else {
      std::fprintf(stderr, "bench: %zu/%zu trial %llu %s: %s%s (%.1f s), ETA %s\n", finished, indices.size(),
                   static_cast<unsigned long long>(indices[slot]), line["draw"].value("part", "?").c_str(),
                   line.value("verdict", "?").c_str(),
                   line.contains("cause") ? (" — " + line["cause"].get<std::string>()).c_str() : "",
                   line["seconds"].value("total", 0.0), duration_text(eta).c_str());
    }
  };
  // The line of a trial whose worker died or was killed.
  auto lost = [&](size_t slot, const Failure& cause, double seconds) {
    Draw d;
    try {
      draw_trial(cmd, cells, indices[slot], d);
    } catch (const std::exception&) {
      d.index = indices[slot];
    }
    finish(slot, failed_trial(cmd, cells, d, cause, seconds));
  };

  // A worker is retired after this many trials, its memory with it.
  constexpr int kTrialsPerWorker = 100;
  // A write to a worker that has just died must fail, not end this process.
  struct sigaction ignore = {}, old_pipe = {};
  ignore.sa_handler = SIG_IGN;
  sigaction(SIGPIPE, &ignore, &old_pipe);
  std::vector<Worker> workers(static_cast<size_t>(std::max(1, cmd.jobs)));
  auto retire = [](Worker& w, bool kill_it) {
    if (w.pid < 0) return 0;
    if (kill_it) kill(w.pid, SIGKILL);
    close(w.to);
    close(w.from);
    int status = 0;
    waitpid(w.pid, &status, 0);
    w = Worker();
    return status;
  };
  auto spawn = [&](Worker& w) {
    int to[2], from[2];
    if (pipe(to) != 0 || pipe(from) != 0)
      throw std::runtime_error("bench: pipe() failed: " + std::string(std::strerror(errno)));
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("bench: fork() failed: " + std::string(std::strerror(errno)));
    if (pid == 0) {
      close(to[1]);
      close(from[0]);
      for (const Worker& o : workers)
        if (o.pid > 0) close(o.to), close(o.from);
      worker_main(to[0], from[1], cmd, cells, indices, calibration ? &*calibration : nullptr);
    }
    close(to[0]);
    close(from[1]);
    w = Worker();
    w.pid = pid, w.to = to[1], w.from = from[0];
  };

  while (finished < indices.size() && !write_failed) {
    for (Worker& w : workers) {
      if (w.busy || todo.empty()) continue;
      if (w.pid > 0 && w.handed >= kTrialsPerWorker) retire(w, false);
      if (w.pid < 0) spawn(w);
      w.slot = todo.front();
      w.busy = true;
      w.start = Clock::now();
      ++w.handed;
      w.text.clear();
      if (!write_all(w.to, std::to_string(w.slot) + '\n')) {  // died idle: the trial goes to a new worker
        retire(w, true);
        continue;
      }
      todo.pop_front();
    }
    std::vector<pollfd> polls;
    std::vector<Worker*> polled;
    for (Worker& w : workers)
      if (w.busy) polls.push_back({w.from, POLLIN, 0}), polled.push_back(&w);
    if (polls.empty()) continue;
    poll(polls.data(), polls.size(), 200);
    for (size_t k = 0; k < polls.size(); ++k) {
      Worker& w = *polled[k];
      bool ended = false;
      if (polls[k].revents & (POLLIN | POLLHUP | POLLERR)) {
        char buf[65536];
        const ssize_t n = read(w.from, buf, sizeof buf);
        if (n > 0)
          w.text.append(buf, static_cast<size_t>(n));
        else
          ended = true;
      }
      const double age = std::chrono::duration<double>(Clock::now() - w.start).count();
      const size_t nl = w.text.find('\n');
      if (nl != std::string::npos) {
        json line;
        try {
          line = json::parse(w.text.substr(0, nl));
        } catch (const std::exception&) {
          const size_t slot = w.slot;
          retire(w, true);
          lost(slot, {FailureKind::kCrash, "the trial's line could not be read"}, age);
          continue;
        }
        w.busy = false;
        finish(w.slot, line);
      } else if (ended) {
        const size_t slot = w.slot;
        const int status = retire(w, false);
        Failure cause{FailureKind::kCrash, ""};
        if (WIFSIGNALED(status))
          cause.reason =
              "signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
        else
          cause.reason = "exited with code " + std::to_string(WEXITSTATUS(status)) + " and no result";
        lost(slot, cause, age);
      } else if (age > cmd.timeout_s) {
        const size_t slot = w.slot;
        retire(w, true);
        char cause[96];
        std::snprintf(cause, sizeof cause, "killed after %.0f s", cmd.timeout_s);
        lost(slot, {FailureKind::kTimeout, cause}, age);
      }
    }
  }
  for (Worker& w : workers) retire(w, write_failed);  // on the end of their input, workers exit
  sigaction(SIGPIPE, &old_pipe, nullptr);
  for (const auto& [p, bytes] : shared_rays)
    if (p) munmap(p, bytes);
  if (write_failed)
    throw InputError(cmd.out +
                     ": cannot be written (is the disk full?): the run stopped; the trials saved "
                     "before it are kept, and --resume with the same --out goes on after them");
  const double elapsed = std::chrono::duration<double>(Clock::now() - t_start).count();
  if (tty) std::fprintf(stderr, "\n");
  if (!cmd.quiet)
    std::fprintf(stderr,
                 "bench: %zu trials in %s (%.2f s a trial): ours: seams within 1 mm %zu, welded %zu; %s\n",
                 indices.size(), duration_text(elapsed).c_str(),
                 elapsed / std::max<double>(1.0, static_cast<double>(indices.size())), ours_ok, passed,
                 cmd.out.c_str());
  return 0;
}

}  // namespace weldtwin
