// The record of a trajectory run on a robot (DIR/execution.json): where it ran, which plan, what was sent,
// every joint state the robot reported, and how it ended. Written for a completed run and for a failed one
// alike (a RobotError carries the log up to the failure).
#pragma once

#include <string>

#include "hw/robot_driver.hpp"

namespace weldtwin {

struct ExecutionRecord {
  std::string robot;        ///< the driver's describe()
  std::string plan_sha256;  ///< the plan file that was run
  double speed_fraction = 1.0;
  ExecutionLog log;
  std::string outcome;  ///< "completed", or the RobotError's message
};

/// Writes `record` as JSON to `path`. Throws std::runtime_error naming the path when it cannot be written.
void write_execution_record(const std::string& path, const ExecutionRecord& record);

}  // namespace weldtwin
