// weldtwin-cell: every command of weldtwin (app/main.cpp answers `weldtwin localize` itself and hands every
// other command to this program). Exit codes: 0 done, 2 bad input (one line on stderr naming the file and the
// problem), 3 the job ran but its answer is not trustworthy, 1 an internal error.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "app/bench_command.hpp"
#include "app/calibrate_command.hpp"
#include "app/command_line.hpp"
#include "app/localize_command.hpp"
#include "app/plan_command.hpp"
#include "app/reach_command.hpp"
#include "app/robot_gate.hpp"
#include "app/run_command.hpp"
#include "app/scan_command.hpp"
#include "core/error.hpp"
#include "pipeline/outcome.hpp"

int main(int argc, char** argv) {
  weldtwin::keep_freed_memory_for_reuse();
  CLI::App app;
  weldtwin::describe_weldtwin(app);
  app.require_subcommand(1);

  weldtwin::RunCommand run;
  uint64_t run_seed = 0;
  bool no_renders = false;
  CLI::App* rc = app.add_subcommand(
      "run",
      "The whole job: sweep (the twin's, a recording, or a live LiDAR on the arm) -> localization -> plan -> "
      "replay in MuJoCo -> report (DIR/report.html, DIR/report.json) -> with --robot, a dry run or (with "
      "--execute, and only after a passed replay) the plan on the robot; exit 0 PASS, 2 bad input, 3 FAIL "
      "(also a refused --execute or a robot error), 130 stopped by Ctrl-C");
  rc->add_option("cell", run.cell, "cell file (default: scenes/cells/default.yaml)")
      ->check(CLI::ExistingFile);
  CLI::Option* run_seed_opt = rc->add_option(
      "--seed", run_seed, "draw the part pose (any yaw, anywhere within reach), 2-4 clamps and clutter");
  rc->add_option("--out", run.out, "output directory (default: out/run)");
  rc->add_flag("--no-renders", no_renders, "figures only: no OSMesa pictures or plots (faster)");
  rc->add_option("--threads", run.threads, "ray-casting threads (default: all cores)");
  rc->add_option(
        "--source", run.source,
        "where the sweep comes from: sim (the twin, default); log:FILE — a recorded sweep (ScanLog, "
        "ROS 1 bag, ROS 2 bag directory); lidar:DEV — a live RPLIDAR A2 (e.g. lidar:/dev/ttyUSB0) while "
        "--robot runs the cell's sweep program (needs --execute). The cell (and --seed) still stand for "
        "the twin the plan is replayed in")
      ->capture_default_str();
  rc->add_option("--mount-error-mm", run.mount_error_mm,
                 "twin only: the LiDAR's real mount is off by X Y Z mm")
      ->expected(3);
  rc->add_option("--mount-error-deg", run.mount_error_deg, "twin only: and by roll pitch yaw deg")
      ->expected(3);
  rc->add_option("--lidar-mount", run.lidar_mount,
                 "mount JSON of weldtwin calibrate: assemble the scan with the calibrated LiDAR mount")
      ->check(CLI::ExistingFile);
  CLI::Option* robot_opt = rc->add_option(
      "--robot", run.robot,
      "the arm: sim (the twin, default) or aubo://HOST[:RPC_PORT[:RTDE_PORT]] (an Aubo ARCS controller: "
      "JSON-RPC on 30004, RTDE on 30010). Given, the run ends with a dry run: the requests that would be "
      "sent, in DIR/robot_dry_run.json");
  rc->add_flag("--execute", run.execute,
               "send the plan to --robot: only the plan whose replay passed in this run (its SHA-256 is in "
               "the passed report), recorded in DIR/execution.json; Ctrl-C stops the arm and waits for it to "
               "halt");
  rc->add_flag("!--no-guidance", run.guidance,
               "when the part cannot be welded where it lies, do not look for where it could be (by default "
               "the nearest placement that plans and replays clean in the twin is named, and with the "
               "report's pictures the table's weldability map is drawn)");
  rc->add_option("--speed", run.speed_fraction, "speed override on the robot, (0, 1] (default 1)")
      ->check(CLI::Range(1e-3, 1.0));
  rc->add_option("--robot-timeout-s", run.robot_timeout_s,
                 "timeout of every exchange with the robot controller [s] (default 2)")
      ->check(CLI::PositiveNumber);
  rc->add_flag("-q,--quiet", run.quiet, "no progress lines");

  weldtwin::ReplayCommand replay;
  uint64_t replay_seed = 0;
  bool replay_no_renders = false;
  CLI::App* rp = app.add_subcommand(
      "replay",
      "Replay a plan in the twin (servos, contacts, clearance, distance to the true seams) and write "
      "the report; exit 0 passed, 3 failed");
  rp->add_option("plan", replay.plan, "plan JSON (as weldtwin plan or run writes it)")
      ->required()
      ->check(CLI::ExistingFile);
  rp->add_option("cell", replay.cell, "cell file (default: scenes/cells/default.yaml)")
      ->check(CLI::ExistingFile);
  CLI::Option* replay_seed_opt =
      rp->add_option("--seed", replay_seed, "the cell's layout drawn from this seed");
  rp->add_option("--out", replay.out, "output directory (default: out/replay)");
  rp->add_flag("--no-renders", replay_no_renders, "figures only: no OSMesa pictures or plots");
  rp->add_flag("-q,--quiet", replay.quiet, "no progress lines");

  weldtwin::ScanCommand scan;
  uint64_t seed = 0;
  CLI::App* sc = app.add_subcommand("scan",
                                    "Simulate the cell's LiDAR sweep: write the ScanLog, and optionally the "
                                    "base-frame cloud and the truth");
  sc->add_option("cell", scan.cell, "cell file (scenes/cells/*.yaml)")->required()->check(CLI::ExistingFile);
  CLI::Option* seed_opt = sc->add_option(
      "--seed", seed, "draw the part pose (any yaw, anywhere within reach), 2-4 clamps and clutter");
  sc->add_option("--out", scan.out_log, "ScanLog to write (format: docs/scanlog.md)")->required();
  sc->add_option("--cloud", scan.cloud, "base-frame point cloud to write (.pcd, binary)");
  sc->add_option("--truth", scan.truth,
                 "ground truth to write (.json): T_base_part, clamps, per-point labels");
  sc->add_option("--mjcf", scan.mjcf, "save the composed MuJoCo model of the cell (.xml)");
  sc->add_option("--rosbag", scan.rosbag1,
                 "also write the sweep as a ROS 1 bag (.bag: sensor_msgs/LaserScan on /scan, one per turn; "
                 "sensor_msgs/JointState on /joint_states)");
  sc->add_option("--rosbag2", scan.rosbag2, "also write the sweep as a ROS 2 bag directory (CDR messages)");
  sc->add_option("--rosbag2-storage", scan.rosbag2_storage, "the ROS 2 bag's storage: sqlite3 or mcap")
      ->check(CLI::IsMember({"sqlite3", "mcap"}))
      ->capture_default_str();
  sc->add_flag("--noise-free", scan.noise_free,
               "exact ranges: no noise, quantisation, dropouts or mixed pixels");
  sc->add_option("--threads", scan.threads, "ray-casting threads (default: all cores)");
  sc->add_flag("-q,--quiet", scan.quiet, "no progress lines");

  weldtwin::LocalizeCommand loc;
  CLI::App* lc = weldtwin::add_localize_command(app, loc);

  weldtwin::PlanCommand plan;
  CLI::App* pc =
      app.add_subcommand("plan", "Plan the welds of a part at a pose: timed torch path and 200 Hz joints");
  pc->add_option("--part", plan.part, "part spec (scenes/parts/*.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  pc->add_option("--pose", plan.pose, "pose JSON with T_base_part (as weldtwin localize writes it)")
      ->required()
      ->check(CLI::ExistingFile);
  pc->add_option(
      "--cell", plan.cell,
      "cell file: its robot, and its table, clamps and clutter to plan around (default: the default "
      "cell's robot, joint limits only)");
  pc->add_option("--out", plan.out, "plan JSON to write")->required();
  pc->add_option("--csv", plan.csv, "joint trajectory CSV to write (t,j1..j6)");
  pc->add_flag("-q,--quiet", plan.quiet, "no progress lines");

  weldtwin::BenchCommand bench;
  std::string shard = "0/1";
  double mount_mm = 0.0, mount_deg = 0.0;
  CLI::App* bc = app.add_subcommand(
      "bench",
      "Randomized-pose benchmark: N random cells (part, pose, yaw, 2-4 clamps, clutter, LiDAR noise), each "
      "swept, localized by ours and the paper's method on the same scan, planned and replayed; one JSON line "
      "per trial. Trials are seeded by (seed, index): shards run on machines of one kind merge into exactly "
      "the lines of one run (see docs/bench.md)");
  bc->add_option("--trials", bench.trials, "trials in the whole benchmark (all shards)")
      ->capture_default_str();
  bc->add_option("--seed", bench.seed, "benchmark seed")->capture_default_str();
  bc->add_option("--jobs", bench.jobs, "trials at once, in as many worker processes (default: one per core)");
  bc->add_option("--shard", shard,
                 "K/N: run only the trials whose index i has i % N == K (K from 0), for splitting across "
                 "machines")
      ->capture_default_str();
  bc->add_option("--out", bench.out, "results, JSON lines in index order")->required();
  bc->add_option("--cell", bench.cells,
                 "the cells whose parts are drawn (repeat; default: the three of scenes/cells)")
      ->check(CLI::ExistingFile);
  bc->add_flag("!--no-paper", bench.paper, "skip the paper's pipeline");
  bc->add_flag("!--no-replay", bench.replay, "localization only: no plan, no replay");
  bc->add_flag("!--spec-angles-only", bench.weld_window,
               "plan every seam at its spec's nominal work and travel angles, in its direction and in the "
               "spec's order only (no search of the angle windows, the other direction or the seam order)");
  bc->add_option("--sweep", bench.sweep,
                 "sweep program for every cell, e.g. scenes/sweeps/one_pass.yaml "
                 "(default: each cell's own; it replaces the cell's rescan too)");
  bc->add_option("--rescan", bench.rescans,
                 "where the part is not found, sweep this program too and seek it in all sweeps, e.g. "
                 "scenes/sweeps/crossing_pass.yaml after one_pass.yaml (it starts where the sweep ends); "
                 "given again, the next program swept while the part is still not found (default: the "
                 "cell's own rescans, if any)")
      ->allow_extra_args(false)
      ->check(CLI::ExistingFile);
  bc->add_option(
        "--robot", bench.robot,
        "robot file (arm and tooling) for every cell, e.g. scenes/robots/aubo_i5_bent22_cell.yaml for "
        "the 22 deg swan-neck torch or scenes/robots/aubo_i5_cell.yaml for the straight one (default: each "
        "cell's own, the 45 deg swan neck)")
      ->check(CLI::ExistingFile);
  std::string placement;
  bc->add_option("--placement", placement,
                 "where parts are drawn: 'ring' (the seams 0.40-0.56 m from the robot axis, within 75 deg of "
                 "its front) or 'table' (anywhere on the table top where part and clamps fit, clear of the "
                 "robot base); default: each cell's own (the shipped cells: ring)")
      ->check(CLI::IsMember({"ring", "table"}));
  bc->add_flag(
      "--guidance", bench.guidance,
      "for a trial that fails though the part was found within 1 mm: the placement weldtwin run would "
      "suggest, then the whole trial again (sweep, localize, plan, replay) with the part moved there");
  bc->add_flag("!--no-viewpoints", bench.viewpoints,
               "localize without the points' viewpoints, as clouds from other tools come");
  double replay_step_ms = 5.0;
  bc->add_option(
        "--replay-step-ms", replay_step_ms,
        "physics step of the replay (weldtwin run uses 2.5 ms; 5 ms: same verdicts, seam errors within "
        "5 um, half the time)")
      ->capture_default_str();
  bc->add_option("--timeout-s", bench.timeout_s, "a trial running longer is killed and recorded as failed")
      ->capture_default_str();
  bc->add_option("--mount-error-mm", mount_mm, "LiDAR mount error drawn per trial: sigma per axis [mm]");
  bc->add_option("--mount-error-deg", mount_deg, "LiDAR mount error drawn per trial: sigma per axis [deg]");
  bc->add_flag(
      "--calibrate", bench.calibrate,
      "each trial first finds the LiDAR mount from a sweep of the calibration cell through its mount "
      "error (as weldtwin calibrate), and assembles its scan with it");
  bc->add_flag(
      "--resume", bench.resume,
      "keep the finished trials already in --out (of a stopped run of the same benchmark), run the rest");
  bc->add_option("--encoder-noise-rad", bench.encoder_noise_rad, "joint encoder noise sigma [rad]");
  bc->add_option(
      "--keep-failed", bench.keep_failed,
      "DIR: keep each failed trial's scan (PCD), poses and plan in DIR/trial-INDEX/ (to look again "
      "with weldtwin replay / localize)");
  bc->add_option("--fault", bench.faults, "for tests: INDEX:crash|hang|throw (repeatable)")->group("");
  bc->add_flag("-q,--quiet", bench.quiet, "no progress output");

  weldtwin::BenchReportCommand bench_report;
  CLI::App* br = app.add_subcommand(
      "bench-report",
      "Merge benchmark shards and write DIR/results.jsonl, DIR/summary.json (success rates with 95 % "
      "intervals, error percentiles per part, time per stage, failure causes) and DIR/report.html (plots)");
  br->add_option("results", bench_report.inputs, "JSON-lines files of one benchmark (its shards)")
      ->required()
      ->check(CLI::ExistingFile);
  br->add_option("--out", bench_report.out, "output directory (default: out/bench)");

  weldtwin::CalibrateCommand cal;
  uint64_t cal_seed = 0;
  CLI::App* cc = app.add_subcommand(
      "calibrate",
      "Find the LiDAR's mount on link 5 from a sweep of the calibration cell (the bare table and a known "
      "box) "
      "and write the correction to the URDF's mount; exit 0 calibrated, 3 untrustworthy fit");
  cc->add_option("cell", cal.cell, "calibration cell (default: scenes/cells/calibration.yaml)")
      ->check(CLI::ExistingFile);
  cc->add_option("--source", cal.source,
                 "sim (the twin) or log:FILE (a recorded sweep of the calibration cell)")
      ->capture_default_str();
  CLI::Option* cal_seed_opt = cc->add_option("--seed", cal_seed, "LiDAR noise seed of the twin's sweep");
  cc->add_option("--mount-error-mm", cal.mount_error_mm,
                 "twin only: sweep through a mount off by X Y Z mm (to check the calibration)")
      ->expected(3);
  cc->add_option("--mount-error-deg", cal.mount_error_deg, "twin only: and by roll pitch yaw deg")
      ->expected(3);
  cc->add_option("--out", cal.out, "mount JSON to write")->required();
  cc->add_option("--urdf-out", cal.urdf_out,
                 "also write the robot's URDF with the calibrated LiDAR mount (everything else as it was)");
  cc->add_flag("-q,--quiet", cal.quiet, "no progress line");

  weldtwin::ReachCommand reach;
  CLI::App* wc = app.add_subcommand(
      "reach",
      "Where on the cell's table the part can be welded: a map of placements (a grid of positions, every "
      "yaw step; the part held by the cell's clamp sites), each judged by whether every seam's stations, "
      "approach and departure are reached clear of the table, clamps, clutter and part with the planner's "
      "angle windows and directions. Writes DIR/map.png (green: welds at that share of yaws; red: the arm "
      "collides; orange: out of reach; grey: no room) and DIR/map.json");
  wc->add_option("part", reach.part, "part spec (YAML)")->required()->check(CLI::ExistingFile);
  wc->add_option("cell", reach.cell, "cell (default: scenes/cells/default.yaml)")->check(CLI::ExistingFile);
  wc->add_option("--robot", reach.robot, "robot file (arm and tooling) instead of the cell's")
      ->check(CLI::ExistingFile);
  wc->add_option("--out", reach.out, "output directory")->capture_default_str();
  wc->add_option("--grid-mm", reach.grid_mm, "spacing of the positions on the table [mm]")
      ->capture_default_str();
  wc->add_option("--yaw-step-deg", reach.yaw_step_deg, "spacing of the yaws [deg]")->capture_default_str();
  wc->add_flag("-q,--quiet", reach.quiet, "no progress line");

  if (const int code = weldtwin::parse_command_line(app, argc, argv); code >= 0) return code;
  try {
    if (bc->parsed()) {
      const size_t slash = shard.find('/');
      try {
        if (slash == std::string::npos) throw std::invalid_argument(shard);
        bench.shard = std::stoi(shard.substr(0, slash));
        bench.shards = std::stoi(shard.substr(slash + 1));
      } catch (const std::exception&) {
        throw weldtwin::InputError("--shard: '" + shard + "' is not K/N");
      }
      if (!placement.empty()) bench.placement = weldtwin::placement_area_from(placement);
      bench.mount_error_m = 1e-3 * mount_mm;
      bench.replay_step_s = 1e-3 * replay_step_ms;
      bench.mount_error_rad = weldtwin::deg2rad(mount_deg);
      return weldtwin::run_bench(bench);
    }
    if (br->parsed()) return weldtwin::run_bench_report(bench_report);
    if (wc->parsed()) return weldtwin::run_reach(reach);
    if (cc->parsed()) {
      if (*cal_seed_opt) cal.seed = cal_seed;
      return weldtwin::run_calibrate(cal);
    }
    if (rp->parsed()) {
      if (*replay_seed_opt) replay.seed = replay_seed;
      replay.renders = !replay_no_renders;
      return weldtwin::run_replay(replay);
    }
    if (rc->parsed()) {
      if (*run_seed_opt) run.seed = run_seed;
      run.renders = !no_renders;
      run.robot_given = robot_opt->count() > 0;
      return weldtwin::run_job(run);
    }
    if (sc->parsed()) {
      if (*seed_opt) scan.seed = seed;
      return weldtwin::run_scan(scan);
    }
    if (pc->parsed()) return weldtwin::run_plan(plan);
    if (lc->parsed()) return weldtwin::run_localize(loc);
  } catch (const weldtwin::RobotError& e) {
    std::fprintf(stderr, "weldtwin: robot: %s\n", e.what());
    return weldtwin::kExitUntrustworthy;
  } catch (const weldtwin::GateRefused& e) {
    std::fprintf(stderr, "weldtwin: refused: %s\n", e.what());
    return weldtwin::kExitUntrustworthy;
  } catch (const std::exception& e) {
    return weldtwin::exit_code_for(e);
  }
  return 0;
}
