// Shared fixtures for the tests: repository paths and a loaded cell.
#pragma once

#include <memory>
#include <optional>
#include <random>
#include <string>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin::test {

inline std::string repo(const std::string& relative) {
  return std::string(WELDTWIN_SOURCE_DIR) + "/" + relative;
}

/// Everything a sim test needs about one cell.
struct Cell {
  CellSpec spec;
  PartSpec part;
  RobotModel robot;
  CellLayout layout;
  std::unique_ptr<MujocoWorld> world;

  explicit Cell(const std::string& cell_file = "scenes/cells/default.yaml", std::optional<uint64_t> seed = {})
      : spec(CellSpec::load(repo(cell_file))),
        part(PartSpec::load(spec.part_spec)),
        robot(RobotModel::load(spec.robot_urdf)),
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

}  // namespace weldtwin::test
