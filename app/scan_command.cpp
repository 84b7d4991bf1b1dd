#include "app/scan_command.hpp"

#include "hw/ros_bags.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "app/json_file.hpp"
#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/cloud_io.hpp"
#include "core/part_spec.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/seam_coverage.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin {
int run_scan(const ScanCommand& cmd) {
  auto say = [&](const std::string& line) {
    if (!cmd.quiet) std::fprintf(stderr, "scan: %s\n", line.c_str());
  };
  const CellSpec cell = CellSpec::load(cmd.cell);
  const PartSpec part = PartSpec::load(cell.part_spec);
  const RobotModel robot = load_cell_robot(cell);
  const SweepProgram program = SweepProgram::load(cell.sweep_program, robot);
  LidarSetting lidar;
  lidar.apply(cell.lidar_overrides, cell.source);
  if (cmd.seed) lidar.seed = *cmd.seed;
  if (cmd.noise_free) lidar = lidar.noise_free();
  const CellLayout layout = make_layout(cell, part, cmd.seed);
  const MujocoWorld world(cell, part, robot, layout);
  if (!cmd.mjcf.empty()) {
    write_text_file(cmd.mjcf, world.mjcf());
    say("wrote the composed MJCF to " + cmd.mjcf);
  }

  char line[256];
  std::snprintf(line, sizeof line,
                "cell '%s', part '%s' at (%.3f, %.3f) m, %zu clamps, %zu clutter; sweep %.1f s",
                cell.name.c_str(), part.name.c_str(), layout.T_base_part.translation().x(),
                layout.T_base_part.translation().y(), layout.clamps.size(), layout.clutter.size(),
                program.duration_s());
  say(line);
  SweepOptions options;
  options.threads = cmd.threads;
  int last_decile = -1;
  options.progress = [&](double f) {
    const int decile = static_cast<int>(f * 10);
    if (decile != last_decile && !cmd.quiet) std::fprintf(stderr, "scan: sweeping %3d %%\n", decile * 10);
    last_decile = decile;
  };
  const SweepResult sweep = simulate_sweep(world, robot, program, lidar, options);
  std::snprintf(line, sizeof line, "%zu samples, %zu returns, simulated in %.2f s (%.0fx real time)",
                sweep.log.samples.size(), sweep.log.valid_samples(), sweep.wall_s,
                program.duration_s() / sweep.wall_s);
  say(line);

  sweep.log.write(cmd.out_log);
  say("wrote the scan log to " + cmd.out_log);
  if (!cmd.rosbag1.empty()) {
    write_ros1_bag(cmd.rosbag1, sweep.log);
    say("wrote the sweep as a ROS 1 bag to " + cmd.rosbag1);
  }
  if (!cmd.rosbag2.empty()) {
    write_ros2_bag(cmd.rosbag2, sweep.log, 1.7e9,
                   cmd.rosbag2_storage == "mcap" ? Ros2Storage::kMcap : Ros2Storage::kSqlite3);
    say("wrote the sweep as a ROS 2 bag (" + cmd.rosbag2_storage + ") to " + cmd.rosbag2);
  }

  if (cmd.cloud.empty() && cmd.truth.empty()) return 0;
  const AssembledCloud cloud = assemble_scan(sweep.log, robot);
  if (!cmd.cloud.empty()) {
    write_pcd(cmd.cloud, cloud.points_base, false, &cloud.viewpoints_base);
    say("wrote " + std::to_string(cloud.points_base.size()) + " points to " + cmd.cloud);
  }
  if (cmd.truth.empty()) return 0;

  // Ground truth: poses, and a label per cloud point (run-length coded, in cloud order).
  nlohmann::json truth;
  truth["cell"] = cell.source;
  truth["seed"] = cmd.seed ? nlohmann::json(*cmd.seed) : nlohmann::json(nullptr);
  truth["part"] = part.name;
  truth["part_spec"] = part.source;
  truth["part_mesh"] = part.mesh_path;
  truth["T_base_part"] = transform_json(layout.T_base_part);
  for (const auto& c : layout.clamps)
    truth["clamps"].push_back({{"site", c.site}, {"T_base_clamp", transform_json(c.T_base_clamp)}});
  for (const auto& c : layout.clutter)
    truth["clutter"].push_back({{"type", c.type == ClutterItem::Type::kBox ? "box" : "cylinder"},
                                {"size_m", {c.size_m.x(), c.size_m.y(), c.size_m.z()}},
                                {"x_m", c.x_m},
                                {"y_m", c.y_m},
                                {"yaw_rad", c.yaw_rad}});
  truth["noise_free"] = cmd.noise_free;
  truth["points"] = cloud.points_base.size();
  truth["label_names"] = {"none", "part", "table", "clamp", "robot", "other"};
  nlohmann::json rle = nlohmann::json::array();
  std::vector<Vec3> part_points;
  std::map<std::string, size_t> counts;
  for (size_t k = 0; k < cloud.sample_index.size(); ++k) {
    const Label label = sweep.labels[cloud.sample_index[k]];
    counts[label_name(label)]++;
    if (label == Label::kPart) part_points.push_back(cloud.points_base[k]);
    const int v = static_cast<int>(label);
    if (!rle.empty() && rle.back()[0] == v) {
      rle.back()[1] = rle.back()[1].get<size_t>() + 1;
    } else {
      rle.push_back({v, 1});
    }
  }
  truth["point_labels_rle"] = rle;
  truth["label_counts"] = counts;
  for (const SeamCoverage& c : seam_coverage(part, layout.T_base_part, part_points))
    truth["seam_coverage"].push_back({{"seam", c.seam},
                                      {"seen_fraction", c.fraction()},
                                      {"seen_one_member_fraction", c.fraction_one()},
                                      {"stations", c.stations},
                                      {"points_near", c.points_near}});
  truth["sweep"] = {{"duration_s", program.duration_s()},
                    {"samples", sweep.log.samples.size()},
                    {"returns", sweep.log.valid_samples()},
                    {"wall_s", sweep.wall_s}};
  write_json_file(cmd.truth, truth);
  say("wrote the ground truth to " + cmd.truth + " (" + std::to_string(counts["part"]) + " part points)");
  return 0;
}

}  // namespace weldtwin
