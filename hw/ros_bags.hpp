// Recorded sweeps from ROS: a ROS 1 bag (Debian's librosbag) or a ROS 2 bag (its sqlite3 or MCAP storage,
// CDR messages) holding sensor_msgs/LaserScan (one message per LiDAR turn, as the RPLIDAR drivers publish)
// and the arm's poses — sensor_msgs/JointState, or, in a recording without joint states, the arm's links as
// tf2_msgs/TFMessage on /tf (robot_state_publisher's transforms, read back into joint angles:
// hw/tf_joints.hpp) — turned into a ScanLog — and ScanLogs written as such bags (to record a twin
// sweep the way a real cell would, and for the tests).
//
// Time alignment: both topics carry header stamps on one clock; the log's zero is the earliest of them, each
// LiDAR sample's time is its scan's stamp plus its index times time_increment, and scan assembly interpolates
// the joint states at every sample's own time.
#pragma once

#include <string>

#include "core/robot_model.hpp"
#include "core/scan_log.hpp"

namespace weldtwin {

/// Which topics to read ("" = the first of the right type).
struct BagTopics {
  std::string scan;
  std::string joints;
};

/// Reads a ROS 1 bag. Joint states are reordered into the robot's joint order. Throws InputError naming the
/// file for an unreadable bag, a missing topic, a joint the robot has not, or messages out of order.
ScanLog read_ros1_bag(const std::string& path, const RobotModel& robot, const BagTopics& topics = {});

/// Reads a ROS 2 bag: its directory (with one .db3 or .mcap storage file) or the storage file itself. Both of
/// rosbag2's storages: sqlite3, and MCAP (its default since Iron; uncompressed, lz4 or zstd chunks).
ScanLog read_ros2_bag(const std::string& path, const RobotModel& robot, const BagTopics& topics = {});

/// Writes `log` as a ROS 1 bag (/scan, /joint_states), stamps from `epoch_s` on. Every turn must have evenly
/// spaced angles (a LaserScan holds a start and an increment). With `tf_robot`, the arm's poses go on /tf as
/// that robot's joint transforms instead of /joint_states. Throws std::runtime_error when it cannot.
void write_ros1_bag(const std::string& path, const ScanLog& log, double epoch_s = 1.7e9,
                    const RobotModel* tf_robot = nullptr);

enum class Ros2Storage { kSqlite3, kMcap };

/// Writes `log` as a ROS 2 bag directory `dir` (metadata.yaml and `<name>_0.db3` or `<name>_0.mcap`); the
/// arm's poses on /tf with `tf_robot`, as write_ros1_bag.
void write_ros2_bag(const std::string& dir, const ScanLog& log, double epoch_s = 1.7e9,
                    Ros2Storage storage = Ros2Storage::kSqlite3, const RobotModel* tf_robot = nullptr);

}  // namespace weldtwin
