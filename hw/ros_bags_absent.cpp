// The ROS bag readers and writers of a build without ROS bag support (WELDTWIN_WITH_ROSBAG=OFF): each says
// so, naming the file, and how to build with it.
#include "core/error.hpp"
#include "hw/ros_bags.hpp"

namespace weldtwin {

namespace {

[[noreturn]] void without_bags(const std::string& path) {
  throw input_error(
      path,
      "a ROS bag, and this weldtwin was built without ROS bag support (WELDTWIN_WITH_ROSBAG=OFF); "
      "configure with -DWELDTWIN_WITH_ROSBAG=ON to read and write bags");
}

}  // namespace

ScanLog read_ros1_bag(const std::string& path, const RobotModel&, const BagTopics&) {
  without_bags(path);
}

ScanLog read_ros2_bag(const std::string& path, const RobotModel&, const BagTopics&) {
  without_bags(path);
}

void write_ros1_bag(const std::string& path, const ScanLog&, double, const RobotModel*) {
  without_bags(path);
}

void write_ros2_bag(const std::string& dir, const ScanLog&, double, Ros2Storage, const RobotModel*) {
  without_bags(dir);
}

}  // namespace weldtwin
