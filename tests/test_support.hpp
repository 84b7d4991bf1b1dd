// Shared fixtures for the tests: repository paths and a loaded cell.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/sweep_program.hpp"
#include "sim/sweep_sim.hpp"

namespace weldtwin::test {

inline std::string repo(const std::string& relative) {
  return std::string(WELDTWIN_SOURCE_DIR) + "/" + relative;
}

/// A copy of the repository's cell `cell_file` at the twin's default LiDAR noise: its `lidar:` line left out,
/// its paths made absolute, written to `copy_path`, which is returned.
inline std::string at_twin_noise(const std::string& cell_file, const std::string& copy_path) {
  std::ifstream in(repo(cell_file));
  const std::filesystem::path folder = std::filesystem::path(repo(cell_file)).parent_path();
  const std::string cells = folder.string() + "/", above = folder.parent_path().string() + "/";
  std::string text, line;
  while (std::getline(in, line)) {
    if (line.rfind("lidar:", 0) == 0) continue;
    for (size_t at = line.find("../"); at != std::string::npos; at = line.find("../", at + above.size()))
      line.replace(at, 3, above);
    if (line.rfind("environment: ", 0) == 0) line.insert(13, cells);
    text += line + "\n";
  }
  std::ofstream(copy_path) << text;
  return copy_path;
}

inline CellSpec load_with_robot(const std::string& cell_file, const std::string& robot_file) {
  CellSpec spec = CellSpec::load(repo(cell_file));
  if (!robot_file.empty()) spec.use_robot_file(repo(robot_file));
  return spec;
}

/// Everything a sim test needs about one cell.
struct Cell {
  CellSpec spec;
  PartSpec part;
  RobotModel robot;
  CellLayout layout;
  std::unique_ptr<MujocoWorld> world;

  /// `robot_file` (repository path): another robot file in place of the cell's own, e.g. the straight torch.
  explicit Cell(const std::string& cell_file = "scenes/cells/default.yaml", std::optional<uint64_t> seed = {},
                const std::string& robot_file = "")
      : spec(load_with_robot(cell_file, robot_file)),
        part(PartSpec::load(spec.part_spec)),
        robot(load_cell_robot(spec)),
        layout(make_layout(spec, part, seed)),
        world(std::make_unique<MujocoWorld>(spec, part, robot, layout)) {}
};

/// Joint angles uniform within the limits.
inline JointVector random_q(const RobotModel& robot, std::mt19937_64& rng) {
  JointVector q;
  for (int j = 0; j < 6; ++j)
    q[j] = std::uniform_real_distribution<double>(robot.lower()[j], robot.upper()[j])(rng);
  return q;
}

struct TwinScan {
  std::vector<Vec3> cloud;
  std::vector<Label> labels;
  Iso3 truth;
  PartSpec part;
  std::vector<Vec3> viewpoints;  ///< where the LiDAR was when it saw each point
};

// A twin scan with the default LiDAR noise, seeded like the localization survey (layout and noise seed).
inline TwinScan twin_scan(const std::string& cell_file, uint64_t seed) {
  Cell cell(cell_file, seed);
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  LidarSetting lidar;
  lidar.seed = seed;
  const SweepResult sweep = simulate_sweep(*cell.world, cell.robot, program, lidar);
  const AssembledCloud a = assemble_scan(sweep.log, cell.robot);
  TwinScan out{a.points_base, {}, cell.layout.T_base_part, cell.part, a.viewpoints_base};
  for (uint32_t s : a.sample_index) out.labels.push_back(sweep.labels[s]);
  return out;
}

}  // namespace weldtwin::test
