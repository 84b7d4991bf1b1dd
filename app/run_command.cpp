#include "app/run_command.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "app/json_file.hpp"
#include "app/mount_file.hpp"
#include "app/plan_file.hpp"
#include "app/pose_file.hpp"
#include "app/report.hpp"
#include "app/robot_gate.hpp"
#include "core/cell_spec.hpp"
#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/scenes.hpp"
#include "hw/execution_record.hpp"
#include "hw/robot_driver.hpp"
#include "hw/scan_source.hpp"
#include "perception/mesh_io.hpp"
#include "perception/scan_assembly.hpp"
#include "pipeline/outcome.hpp"
#include "pipeline/weld_pipeline.hpp"
#include "sim/placement_guidance.hpp"
#include "sim/sweep_sim.hpp"
#include "sim/weldability.hpp"

namespace weldtwin {
namespace {

// SIGINT while the arm moves: the driver sees the flag at its next state frame, stops the arm and waits for
// it to halt. A second SIGINT ends the process the usual way.
std::atomic<bool> g_stop_requested{false};
extern "C" void request_stop(int) {
  g_stop_requested = true;
  std::signal(SIGINT, SIG_DFL);
}

/// SIGINT stops the arm while this lives.
struct StopOnSigint {
  StopOnSigint() {
    g_stop_requested = false;
    previous = std::signal(SIGINT, request_stop);
  }
  ~StopOnSigint() { std::signal(SIGINT, previous); }
  void (*previous)(int) = SIG_DFL;
};

}  // namespace

int run_job(const RunCommand& cmd) {
  using Clock = std::chrono::steady_clock;
  auto say = [&](const std::string& stage, const std::string& line) {
    if (!cmd.quiet) std::fprintf(stderr, "run: %-9s %s\n", stage.c_str(), line.c_str());
  };
  char buf[512];
  RunRecord run;
  auto stage_start = Clock::now();
  auto stage_done = [&](const char* name) {
    const double s = std::chrono::duration<double>(Clock::now() - stage_start).count();
    run.stage_seconds.emplace_back(name, s);
    stage_start = Clock::now();
    return s;
  };

  // The cell.
  const TwinCell twin_cell(CellSpec::load(cell_or_default(cmd.cell)));
  const CellSpec& cell = twin_cell.cell;
  const PartSpec& part = twin_cell.part;
  const RobotModel& robot = twin_cell.robot;
  const SweepProgram& program = twin_cell.program;
  LidarSetting lidar;
  lidar.apply(cell.lidar_overrides, cell.source);
  if (cmd.seed) lidar.seed = *cmd.seed;
  const CellLayout layout = make_layout(cell, part, cmd.seed);
  // The cell as it is: in the twin, the LiDAR's mount may be put wrong on purpose.
  const bool mount_error = !cmd.mount_error_mm.empty() || !cmd.mount_error_deg.empty();
  if (mount_error && cmd.source != "sim") throw InputError("--mount-error-* is for the twin's sweep only");
  // The scan is assembled with the URDF's mount, or the calibrated one.
  RobotModel assembly = robot;
  if (!cmd.lidar_mount.empty()) {
    const MountCorrection mount = read_mount_file(cmd.lidar_mount);
    if (robot.link_index(mount.lidar_link) < 0)
      throw input_error(cmd.lidar_mount, "the robot has no link '" + mount.lidar_link + "'");
    assembly = robot.with_mount_offset(mount.lidar_link, mount.correction);
  }
  const TwinScene twin(
      twin_cell, layout,
      mount_error ? mount_offset(cmd.mount_error_mm, cmd.mount_error_deg) : Iso3::Identity());
  const MujocoWorld& world = twin.world;
  // The arm: the twin, or a real controller (which sweeps a live LiDAR, and welds after the gate).
  const bool live = cmd.source.rfind("lidar:", 0) == 0;
  if (live && !cmd.execute)
    throw InputError("--source " + cmd.source +
                     ": a live sweep moves the arm: add --execute (the sweep program of " +
                     cell.sweep_program + " is run on " + cmd.robot + ")");
  RobotDriverSetting robot_setting;
  robot_setting.speed_fraction = cmd.speed_fraction;
  robot_setting.timeout_s = cmd.robot_timeout_s;
  robot_setting.stop_request = &g_stop_requested;
  robot_setting.realtime = live;
  const SimRobotInputs twin_robot{&world, &part, &twin_cell.mesh, layout.T_base_part};
  const std::unique_ptr<RobotDriver> driver = make_robot_driver(cmd.robot, robot, twin_robot, robot_setting);
  const bool robot_stage = cmd.execute || cmd.robot_given;
  // Progress lines: "[k/5] name", or "[k/6] name" when a robot stage follows.
  auto step = [&](int k, const char* name) {
    return "[" + std::to_string(k) + "/" + (robot_stage ? "6" : "5") + "]" + (*name ? " " : "") + name;
  };
  bool connected = false;
  auto connect = [&] {
    if (!connected) driver->connect();
    connected = true;
  };
  std::error_code ec;
  std::filesystem::create_directories(cmd.out, ec);
  if (ec) throw input_error(cmd.out, "cannot create the output directory: " + ec.message());
  run.cell = &cell;
  run.part = &part;
  run.layout = &layout;
  run.world = &world;
  std::snprintf(buf, sizeof buf, "cell '%s'%s: %s at (%.3f, %.3f) m, %zu clamps, %zu clutter -> %s",
                cell.name.c_str(), cmd.seed ? (" seed " + std::to_string(*cmd.seed)).c_str() : "",
                part.name.c_str(), layout.T_base_part.translation().x(), layout.T_base_part.translation().y(),
                layout.clamps.size(), layout.clutter.size(), cmd.out.c_str());
  say(step(0, ""), buf);
  stage_done("setup");

  // 1. The sweep (and, where the cell has one, the rescan): each kept as a log, assembled into the cloud.
  // Every run keeps its sweeps: `--source log:DIR/scan.scanlog` replays the first.
  const bool from_log = cmd.source.rfind("log:", 0) == 0;
  std::vector<Vec3> viewpoints;  // of run.cloud's points
  auto sweep = [&](const SweepProgram& sweep_program, uint64_t lidar_seed, const char* log_name,
                   const char* stage_name, const std::string& stage) -> std::optional<int> {
    SimScanInputs sim;
    sim.world = &world;
    sim.robot = &twin.real_robot;
    sim.program = &sweep_program;
    sim.lidar = lidar;
    sim.lidar.seed = lidar_seed;
    sim.options.threads = cmd.threads;
    LiveScanInputs live_inputs;
    live_inputs.driver = driver.get();
    live_inputs.program = &sweep_program;
    ScanLog log;
    const std::unique_ptr<ScanSource> source = make_scan_source(cmd.source, robot, sim, live_inputs);
    if (live) {
      connect();
      say(stage, "sweeping with " + source->describe() + " on " + driver->describe() + " (" +
                     std::to_string(static_cast<int>(sweep_program.duration_s())) +
                     " s; Ctrl-C stops the arm)");
      const StopOnSigint stop_on_sigint;
      try {
        log = source->acquire();
      } catch (const RobotError& e) {
        std::printf("FAIL: robot during the sweep: %s\n", e.what());
        return g_stop_requested ? kExitInterrupted : kExitUntrustworthy;
      }
    } else {
      log = source->acquire();
    }
    log.write(cmd.out + "/" + log_name + ".scanlog");
    run.sweeps.push_back(sweep_program.source());
    AssembledCloud cloud;
    try {
      cloud = assemble_scan(log, assembly);
    } catch (const std::invalid_argument& e) {  // a log of another robot
      throw input_error(cmd.source, e.what());
    }
    run.cloud.insert(run.cloud.end(), cloud.points_base.begin(), cloud.points_base.end());
    viewpoints.insert(viewpoints.end(), cloud.viewpoints_base.begin(), cloud.viewpoints_base.end());
    const std::vector<Label> labels = source->labels();
    if (!labels.empty())
      for (uint32_t k : cloud.sample_index) run.cloud_labels.push_back(labels[k]);
    write_pcd(cmd.out + "/scan.pcd", run.cloud, false, &viewpoints);
    const double sweep_s = log.samples.empty() ? 0.0 : log.samples.back().t_s - log.samples.front().t_s;
    std::snprintf(buf, sizeof buf, "%.1f s sweep from %s, %zu points (%.2f s)", sweep_s,
                  source->describe().c_str(), cloud.points_base.size(), stage_done(stage_name));
    say(stage, buf);
    return std::nullopt;
  };
  if (const std::optional<int> stopped = sweep(program, lidar.seed, "scan", "sweep", step(1, "scan")))
    return *stopped;

  // 2-4. Find the part, plan its seams, replay the plan: judged against the truth where the twin made the
  // scan. The plan starts from where the arm stands when a real one is to execute it.
  WeldJob job;
  job.cell = &twin_cell;
  job.twin = &twin;
  job.T_base_part_twin = layout.T_base_part;
  job.truth_known = cmd.source == "sim";
  WeldPipelineHooks hooks;
  hooks.before_plan = [&](PlanSetting& plan_setting) {
    if (!cmd.execute || cmd.robot == "sim") return;
    connect();
    const JointVector q_now = driver->joint_positions();
    if (!robot.within_limits(q_now))
      throw InputError(driver->describe() + ": the arm reports joints outside the URDF's limits");
    if ((q_now - plan_setting.home).cwiseAbs().maxCoeff() > 1e-3) {
      plan_setting.start = q_now;
      say(step(3, "plan"), "from where the arm stands (not home): " + driver->describe());
    }
  };
  hooks.stage_done = [&](PipelineStage stage, const WeldPipelineResult& r) {
    switch (stage) {
      case PipelineStage::kFind: {
        nlohmann::json j = pose_to_json(r.pose);
        j["method"] = "ours";
        write_json_file(cmd.out + "/pose.json", j);
        char against[64] = "unknown: no truth outside the twin";
        if (r.pose_error)
          std::snprintf(against, sizeof against, "%.3f mm against the truth", 1e3 * r.pose_error->seam_max_m);
        std::snprintf(buf, sizeof buf, "%s: fitness %.2f, coverage %.2f, seam error %s (%.2f s)",
                      r.pose.found ? "found" : ("NOT found: " + r.pose.reason).c_str(), r.pose.fitness,
                      r.pose.coverage, against, stage_done("localize"));
        say(step(2, "find"), buf);
        break;
      }
      case PipelineStage::kPlan: {
        const WeldPlan& plan = *r.plan;
        write_json_file(cmd.out + "/plan.json", plan_to_json(plan, part, robot, r.plan_setting), -1);
        run.plan_sha256 = sha256_of_file(cmd.out + "/plan.json");
        std::snprintf(buf, sizeof buf, "%s%zu seams, %.1f s, %zu samples (%.2f s)",
                      plan.ok() ? "" : ("NOT planned: " + plan.problems.front() + "; ").c_str(),
                      plan.seams.size(), plan.duration_s(), plan.samples.size(), stage_done("plan"));
        say(step(3, "plan"), buf);
        break;
      }
      case PipelineStage::kReplay: {
        const ReplayResult& replay = *r.replay;
        std::snprintf(
            buf, sizeof buf,
            "%s: torch to true seam max %.3f mm, tracking %.2e rad, %zu contacts, clearance %.1f mm (%.2f s)",
            replay.passed() ? "clean" : "FAILED", 1e3 * replay.max_seam_error_m, replay.max_tracking_rad,
            replay.contacts.size(), 1e3 * replay.min_clearance_m, stage_done("replay"));
        say(step(4, "replay"), buf);
        break;
      }
    }
  };
  WeldPipelineResult result = weld_pipeline(run.cloud, viewpoints, job, WeldPipelineSetting(), hooks);
  // Not found in the sweeps so far, or found with too little to spare: the cell's next rescan (a pass from
  // another side), and the part sought in all of them.
  for (size_t k = 0;; ++k) {
    const std::string why = twin_cell.sweep_again_because(result.pose, k);
    if (why.empty()) break;
    const std::string stage = step(1, "rescan");
    if (from_log) {
      say(stage,
          why + "; not swept again: the sweep came from a log (the cell's rescan needs the arm or the twin)");
      break;
    }
    const SweepProgram& rescan = twin_cell.rescans[k];
    run.rescan_reasons.push_back(why);
    say(stage, "after the " + std::string(k == 0 ? "sweep" : "sweeps so far") + ", " + why + ": sweeping " +
                   rescan.source() + " too, and seeking it in " +
                   (k == 0 ? "both" : "all " + std::to_string(k + 2)));
    const std::string log_name = k == 0 ? "rescan" : "rescan" + std::to_string(k + 1);
    if (const std::optional<int> stopped =
            sweep(rescan, rescan_lidar_seed(lidar.seed, k), log_name.c_str(), "rescan", stage))
      return *stopped;
    result = weld_pipeline(run.cloud, viewpoints, job, WeldPipelineSetting(), hooks);
  }
  const PoseEstimate& pose = result.pose;
  run.pose = &pose;
  if (result.pose_error) run.pose_error = *result.pose_error;
  const WeldPlan no_plan;
  run.plan = result.plan ? &*result.plan : &no_plan;
  if (result.replay) run.replay = &*result.replay;
  if (!result.plan) {
    std::snprintf(buf, sizeof buf, "skipped (no pose) (%.2f s)", stage_done("plan"));
    say(step(3, "plan"), buf);
  }
  if (!result.replay) {
    std::snprintf(buf, sizeof buf, "skipped: nothing to replay (%.2f s)", stage_done("replay"));
    say(step(4, "replay"), buf);
  }

  // Where to put the part when it does not weld where it lies: the nearest placement that plans and replays
  // clean in the twin, and (with the report's pictures) the map of where it welds on the table.
  PlacementSuggestion suggestion;
  WeldabilityMap weldability;
  const Mesh& mesh = twin_cell.mesh;
  if (cmd.guidance && pose.found && (!run.plan->ok() || (run.replay && !run.replay->passed()))) {
    CellLayout now = layout;
    now.T_base_part = pose.T_base_part;  // where it was found; the clamps and clutter as the cell has them
    GuidanceSetting guide;
    guide.plan = result.plan_setting;
    guide.plan.start.reset();
    suggestion = suggest_placement(cell, part, robot, mesh, now, twin_cell.symmetry, guide);
    run.suggestion = &suggestion;
    std::snprintf(buf, sizeof buf, "%s (%d placements screened, %d planned and replayed; %.1f s)",
                  suggestion.found ? (suggestion.instruction + ": there it plans and replays clean").c_str()
                                   : ("no placement found: " + suggestion.reason).c_str(),
                  suggestion.screened, suggestion.verified, suggestion.seconds);
    say(step(4, "where to put it"), buf);
    if (cmd.renders) {
      const CellSpec map_cell = cell_as_laid_out(cell, layout);
      ReachSetting reach;
      reach.grid_m = 0.04;
      reach.yaw_step_rad = deg2rad(30);
      reach.plan = guide.plan;
      weldability = weldability_map(map_cell, part, robot, mesh, reach);
      run.weldability = &weldability;
      std::snprintf(buf, sizeof buf, "weldability map: %zu of %zu placements with room weld (%.1f s)",
                    weldability.count(PlacementKind::kWelds),
                    weldability.placements.size() - weldability.count(PlacementKind::kNoRoom),
                    weldability.seconds);
      say(step(4, "where to put it"), buf);
    }
  }

  // Verdict.
  for (const Failure& f : result.failures) run.reasons.push_back(f.text());
  run.passed = result.passed();

  // 5. The report.
  const double report_s = write_report(run, cmd.out, cmd.renders);
  stage_done("report");
  std::snprintf(buf, sizeof buf, "%s/report.html (%.2f s)", cmd.out.c_str(), report_s);
  say(step(5, "report"), buf);

  // 6. The robot: a dry run, or — through the gate — the plan executed.
  std::string executed;
  if (robot_stage) {
    const std::string stage = step(6, "robot");
    if (!cmd.execute) {
      if (!run.passed) {
        say(stage, "dry run: nothing would be sent (the run did not pass)");
      } else {
        const JointTrajectory t = plan_trajectory(*run.plan, cmd.out + "/plan.json");
        write_text_file(cmd.out + "/robot_dry_run.json", driver->dry_run(t) + '\n');
        std::snprintf(buf, sizeof buf,
                      "dry run: %zu samples (%.1f s at speed %.2f) would go to %s; requests in "
                      "%s/robot_dry_run.json; --execute sends them",
                      t.q.size(), t.duration_s() / cmd.speed_fraction, cmd.speed_fraction,
                      driver->describe().c_str(), cmd.out.c_str());
        say(stage, buf);
      }
    } else {
      GatedPlan gated;
      try {
        gated = open_gate(cmd.out);
      } catch (const GateRefused& e) {
        std::printf("FAIL: --execute refused: %s; the plan was not sent to %s; report %s/report.html\n",
                    e.what(), driver->describe().c_str(), cmd.out.c_str());
        return kExitUntrustworthy;
      }
      say(stage, "plan " + gated.sha256.substr(0, 12) + " passed its replay: executing on " +
                     driver->describe() + " (Ctrl-C stops the arm)");
      ExecutionLog exec;
      try {
        connect();
        const StopOnSigint stop_on_sigint;
        // A line every 5 s of a long weld.
        double next_line = 5.0;
        const double total_s = gated.trajectory.duration_s() / cmd.speed_fraction;
        exec = driver->execute(gated.trajectory, [&](double, const JointState& js) {
          if (js.t_s < next_line) return;
          next_line += 5.0;
          char line[128];
          std::snprintf(line, sizeof line, "executing: %.0f s of %.0f s", js.t_s, total_s);
          say(stage, line);
        });
      } catch (const RobotError& e) {
        write_execution_record(cmd.out + "/execution.json",
                               {driver->describe(), gated.sha256, cmd.speed_fraction, e.log(), e.what()});
        std::printf("FAIL: robot: %s; record %s/execution.json\n", e.what(), cmd.out.c_str());
        return g_stop_requested ? kExitInterrupted : kExitUntrustworthy;
      }
      write_execution_record(cmd.out + "/execution.json",
                             {driver->describe(), gated.sha256, cmd.speed_fraction, exec, "completed"});
      std::snprintf(buf, sizeof buf, "executed %zu samples in %.1f s; record %s/execution.json",
                    exec.samples_sent, exec.wall_s, cmd.out.c_str());
      say(stage, buf);
      executed = "; executed on " + driver->describe();
    }
  }

  double total = 0.0;
  for (const auto& [name, s] : run.stage_seconds) total += s;
  if (run.passed) {
    std::printf(
        "PASS: every arc-on torch position within %.3f mm of the true seam (max; %s)%s; report "
        "%s/report.html "
        "(%.1f s)\n",
        1e3 * run.replay->max_seam_error_m, tolerance_text(part.weld_tolerance_m).c_str(), executed.c_str(),
        cmd.out.c_str(), total);
    return kExitPassed;
  }
  std::printf("FAIL: %s; report %s/report.html (%.1f s)\n", run.reasons.front().c_str(), cmd.out.c_str(),
              total);
  // The reason on stderr too, naming the input: -q silences progress, not the verdict.
  std::fprintf(stderr, "weldtwin: %s: %s\n", cell_or_default(cmd.cell).c_str(), run.reasons.front().c_str());
  return exit_code(result.failures);
}

int run_replay(const ReplayCommand& cmd) {
  const TwinCell twin_cell(CellSpec::load(cell_or_default(cmd.cell)));
  const CellSpec& cell = twin_cell.cell;
  const PartSpec& part = twin_cell.part;
  const RobotModel& robot = twin_cell.robot;
  const CellLayout layout = make_layout(cell, part, cmd.seed);
  const TwinScene twin(twin_cell, layout);
  const WeldPlan plan = read_plan(cmd.plan);
  check_plan_for_part(plan, part, cmd.plan);
  std::error_code ec;
  std::filesystem::create_directories(cmd.out, ec);
  if (ec) throw input_error(cmd.out, "cannot create the output directory: " + ec.message());
  for (const PlanSample& s : plan.samples)
    if (!robot.within_limits(s.q)) throw input_error(cmd.plan, "a sample leaves the joint limits");
  if (!cmd.quiet)
    std::fprintf(stderr, "replay: %s, %zu samples (%.1f s) in cell '%s'\n", cmd.plan.c_str(),
                 plan.samples.size(), plan.duration_s(), cell.name.c_str());
  const auto t0 = std::chrono::steady_clock::now();
  const ReplayResult replay = replay_in_twin(twin_cell, twin, plan, layout.T_base_part);
  RunRecord run;
  run.cell = &cell;
  run.part = &part;
  run.layout = &layout;
  run.world = &twin.world;
  run.plan = &plan;
  run.replay = &replay;
  run.stage_seconds.emplace_back(
      "replay", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::vector<Failure> failures;
  for (const std::string& f : replay.failures) failures.push_back({FailureKind::kReplay, f});
  for (const Failure& f : failures) run.reasons.push_back(f.text());
  run.passed = failures.empty();
  write_report(run, cmd.out, cmd.renders);
  if (run.passed) {
    std::printf(
        "PASS: every arc-on torch position within %.3f mm of the seam (max; %s); report %s/report.html\n",
        1e3 * replay.max_seam_error_m, tolerance_text(part.weld_tolerance_m).c_str(), cmd.out.c_str());
    return kExitPassed;
  }
  std::printf("FAIL: %s; report %s/report.html\n", run.reasons.front().c_str(), cmd.out.c_str());
  std::fprintf(stderr, "weldtwin: %s: %s\n", cmd.plan.c_str(), run.reasons.front().c_str());
  return exit_code(failures);
}

}  // namespace weldtwin
