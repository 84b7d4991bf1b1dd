// The gate between a plan and a real arm: a plan reaches a robot only when the run's replay in the twin
// passed, and only the very plan that was replayed — DIR/plan.json, whose SHA-256 the passed DIR/report.json
// names. Both files are read back from disk at the gate, so nothing in memory can slip past it.
#pragma once

#include <stdexcept>
#include <string>

#include "hw/robot_driver.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {

/// The gate stays shut; the message says why. Nothing was sent to the robot.
class GateRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// SHA-256 of `bytes`, lower-case hex.
std::string sha256_hex(const std::string& bytes);
/// SHA-256 of a file's bytes; throws InputError naming the file when it cannot be read.
std::string sha256_of_file(const std::string& path);

struct GatedPlan {
  WeldPlan plan;
  std::string sha256;
  JointTrajectory trajectory;  ///< the plan's joints at its 200 Hz step: what the robot is sent
};

/// Opens the gate for run directory `dir`, or throws GateRefused.
GatedPlan open_gate(const std::string& dir);

/// A plan's joints as a trajectory; throws GateRefused unless its samples are evenly spaced.
JointTrajectory plan_trajectory(const WeldPlan& plan, const std::string& source);

}  // namespace weldtwin
