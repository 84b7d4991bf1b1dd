#include "app/run_command.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "app/calibrate_command.hpp"
#include "app/localize_command.hpp"
#include "app/plan_command.hpp"
#include "app/report.hpp"
#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "hw/scan_source.hpp"
#include "perception/cloud_io.hpp"
#include "perception/mesh_io.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/collision_check.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {

int run_job(const RunCommand& cmd) {
  using Clock = std::chrono::steady_clock;
  auto say = [&](const char* stage, const std::string& line) {
    if (!cmd.quiet) std::fprintf(stderr, "run: %-9s %s\n", stage, line.c_str());
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
  const CellSpec cell = CellSpec::load(cell_or_default(cmd.cell));
  const PartSpec part = PartSpec::load(cell.part_spec);
  const RobotModel robot = RobotModel::load(cell.robot_urdf);
  const SweepProgram program = SweepProgram::load(cell.sweep_program, robot);
  const Mesh mesh = load_mesh(part.mesh_path);
  LidarSetting lidar;
  lidar.apply(cell.lidar_overrides, cell.source);
  if (cmd.seed) lidar.seed = *cmd.seed;
  const CellLayout layout = make_layout(cell, part, cmd.seed);
  // The cell as it is: in the twin, the LiDAR's mount may be put wrong on purpose.
  const bool mount_error = !cmd.mount_error_mm.empty() || !cmd.mount_error_deg.empty();
  if (mount_error && cmd.source != "sim") throw InputError("--mount-error-* is for the twin's sweep only");
  const std::string lidar_link = SweepOptions().lidar_link;
  const RobotModel real =
      mount_error ? robot.with_mount_offset(lidar_link, mount_offset(cmd.mount_error_mm, cmd.mount_error_deg))
                  : robot;
  // The scan is assembled with the URDF's mount, or the calibrated one.
  RobotModel assembly = robot;
  if (!cmd.lidar_mount.empty()) {
    std::string link;
    const Iso3 correction = read_mount_correction(cmd.lidar_mount, link);
    if (robot.link_index(link) < 0)
      throw input_error(cmd.lidar_mount, "the robot has no link '" + link + "'");
    assembly = robot.with_mount_offset(link, correction);
  }
  const MujocoWorld world(cell, part, real, layout);
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
  say("[0/5]", buf);
  stage_done("setup");

  // 1. The sweep.
  SimScanInputs sim;
  sim.world = &world;
  sim.robot = &real;
  sim.program = &program;
  sim.lidar = lidar;
  sim.options.threads = cmd.threads;
  const std::unique_ptr<ScanSource> source = make_scan_source(cmd.source, robot, sim);
  const ScanLog log = source->acquire();
  log.write(cmd.out +
            "/scan.scanlog");  // every run keeps its sweep: `--source log:DIR/scan.scanlog` replays it
  AssembledCloud cloud;
  try {
    cloud = assemble_scan(log, assembly);
  } catch (const std::invalid_argument& e) {  // a log of another robot
    throw input_error(cmd.source, e.what());
  }
  write_pcd(cmd.out + "/scan.pcd", cloud.points_base);
  run.cloud = cloud.points_base;
  const std::vector<Label> labels = source->labels();
  if (!labels.empty())
    for (uint32_t k : cloud.sample_index) run.cloud_labels.push_back(labels[k]);
  const double sweep_s = log.samples.empty() ? 0.0 : log.samples.back().t_s - log.samples.front().t_s;
  std::snprintf(buf, sizeof buf, "%.1f s sweep from %s, %zu points (%.2f s)", sweep_s,
                source->describe().c_str(), cloud.points_base.size(), stage_done("sweep"));
  say("[1/5] scan", buf);

  // 2. Localization, judged against the truth only the twin knows.
  const PoseEstimate pose = localize(cloud.points_base, mesh, LocalizeSetting(), part.seam_points(0.001));
  run.pose = &pose;
  run.pose_error = pose_error(part, pose.T_base_part, layout.T_base_part, z_symmetry_order(mesh));
  {
    nlohmann::json j = pose_to_json(pose);
    j["method"] = "ours";
    std::ofstream(cmd.out + "/pose.json") << j.dump(1) << '\n';
  }
  std::snprintf(buf, sizeof buf,
                "%s: fitness %.2f, coverage %.2f, seam error %.3f mm against the truth (%.2f s)",
                pose.found ? "found" : ("NOT found: " + pose.reason).c_str(), pose.fitness, pose.coverage,
                1e3 * run.pose_error.seam_max_m, stage_done("localize"));
  say("[2/5] find", buf);

  // 3. The plan, at the pose found, avoiding what the twin knows of the cell.
  PlanSetting plan_setting;
  WeldPlan plan;
  if (pose.found) {
    // The table, clamps and clutter as the twin has them; the part where it was found.
    CollisionChecker checker(world);
    checker.add_part(mesh, pose.T_base_part);
    plan_setting.collision = checker;
    plan = plan_welds(part, pose.T_base_part, robot, plan_setting);
    std::ofstream(cmd.out + "/plan.json") << plan_to_json(plan, part, robot, plan_setting).dump() << '\n';
  }
  run.plan = &plan;
  std::snprintf(buf, sizeof buf, "%s%zu seams, %.1f s, %zu samples (%.2f s)",
                !pose.found ? "skipped (no pose), "
                : plan.ok() ? ""
                            : ("NOT planned: " + plan.problems.front() + "; ").c_str(),
                plan.seams.size(), plan.duration_s(), plan.samples.size(), stage_done("plan"));
  say("[3/5] plan", buf);

  // 4. The replay.
  ReplayResult replay;
  if (pose.found && plan.ok() && !plan.samples.empty()) {
    replay = replay_plan(world, robot, plan, part, mesh, layout.T_base_part);
    run.replay = &replay;
    std::snprintf(
        buf, sizeof buf,
        "%s: torch to true seam max %.3f mm, tracking %.2e rad, %zu contacts, clearance %.1f mm (%.2f s)",
        replay.passed() ? "clean" : "FAILED", 1e3 * replay.max_seam_error_m, replay.max_tracking_rad,
        replay.contacts.size(), 1e3 * replay.min_clearance_m, stage_done("replay"));
  } else {
    std::snprintf(buf, sizeof buf, "skipped: nothing to replay (%.2f s)", stage_done("replay"));
  }
  say("[4/5] replay", buf);

  // Verdict.
  if (!pose.found) run.reasons.push_back("part not found: " + pose.reason);
  for (const std::string& p : plan.problems) run.reasons.push_back("plan: " + p);
  if (run.replay)
    for (const std::string& f : replay.failures) run.reasons.push_back("replay: " + f);
  run.passed = run.reasons.empty();

  // 5. The report.
  const double report_s = write_report(run, cmd.out, cmd.renders);
  stage_done("report");
  std::snprintf(buf, sizeof buf, "%s/report.html (%.2f s)", cmd.out.c_str(), report_s);
  say("[5/5] report", buf);

  double total = 0.0;
  for (const auto& [name, s] : run.stage_seconds) total += s;
  if (run.passed) {
    std::printf(
        "PASS: every arc-on torch position within %.3f mm of the true seam (max; %s); report %s/report.html "
        "(%.1f s)\n",
        1e3 * replay.max_seam_error_m, "limit 1 mm", cmd.out.c_str(), total);
    return 0;
  }
  std::printf("FAIL: %s; report %s/report.html (%.1f s)\n", run.reasons.front().c_str(), cmd.out.c_str(),
              total);
  return 3;
}

int run_replay(const ReplayCommand& cmd) {
  const CellSpec cell = CellSpec::load(cell_or_default(cmd.cell));
  const PartSpec part = PartSpec::load(cell.part_spec);
  const RobotModel robot = RobotModel::load(cell.robot_urdf);
  const Mesh mesh = load_mesh(part.mesh_path);
  const CellLayout layout = make_layout(cell, part, cmd.seed);
  const MujocoWorld world(cell, part, robot, layout);
  const WeldPlan plan = read_plan(cmd.plan);
  std::error_code ec;
  std::filesystem::create_directories(cmd.out, ec);
  if (ec) throw input_error(cmd.out, "cannot create the output directory: " + ec.message());
  for (const PlanSample& s : plan.samples)
    if (!robot.within_limits(s.q)) throw input_error(cmd.plan, "a sample leaves the joint limits");
  if (!cmd.quiet)
    std::fprintf(stderr, "replay: %s, %zu samples (%.1f s) in cell '%s'\n", cmd.plan.c_str(),
                 plan.samples.size(), plan.duration_s(), cell.name.c_str());
  const auto t0 = std::chrono::steady_clock::now();
  const ReplayResult replay = replay_plan(world, robot, plan, part, mesh, layout.T_base_part);
  RunRecord run;
  run.cell = &cell;
  run.part = &part;
  run.layout = &layout;
  run.world = &world;
  run.plan = &plan;
  run.replay = &replay;
  run.stage_seconds.emplace_back(
      "replay", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  for (const std::string& f : replay.failures) run.reasons.push_back("replay: " + f);
  run.passed = run.reasons.empty();
  write_report(run, cmd.out, cmd.renders);
  if (run.passed) {
    std::printf("PASS: every arc-on torch position within %.3f mm of the seam; report %s/report.html\n",
                1e3 * replay.max_seam_error_m, cmd.out.c_str());
    return 0;
  }
  std::printf("FAIL: %s; report %s/report.html\n", run.reasons.front().c_str(), cmd.out.c_str());
  return 3;
}

}  // namespace weldtwin
