#include "hw/scan_source.hpp"

#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "hw/ros_bags.hpp"

namespace weldtwin {
namespace {

class SimSource : public ScanSource {
 public:
  explicit SimSource(const SimScanInputs& in) : in_(in) {
    if (!in_.world || !in_.robot || !in_.program) throw std::logic_error("sim scan source without a twin");
  }
  std::string describe() const override { return "the twin (simulated)"; }
  ScanLog acquire() override {
    SweepResult r = simulate_sweep(*in_.world, *in_.robot, *in_.program, in_.lidar, in_.options);
    labels_ = std::move(r.labels);
    return std::move(r.log);
  }
  std::vector<Label> labels() const override { return labels_; }

 private:
  SimScanInputs in_;
  std::vector<Label> labels_;
};

class LogSource : public ScanSource {
 public:
  LogSource(std::string path, const RobotModel& robot) : path_(std::move(path)), robot_(robot) {}
  std::string describe() const override { return "the recording " + path_; }
  ScanLog acquire() override { return read_any_scan_log(path_, robot_); }

 private:
  std::string path_;
  const RobotModel& robot_;
};

}  // namespace

ScanLog read_any_scan_log(const std::string& path, const RobotModel& robot) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw input_error(path, "no such file or directory");
  if (fs::is_directory(path)) return read_ros2_bag(path, robot);
  std::ifstream in(path, std::ios::binary);
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string magic(head, static_cast<size_t>(in.gcount()));
  if (magic.rfind("WELDTWIN-SCANLOG", 0) == 0) return ScanLog::read(path);
  if (magic.rfind("#ROSBAG V2.0", 0) == 0) return read_ros1_bag(path, robot);
  if (magic.rfind("SQLite format 3", 0) == 0) return read_ros2_bag(path, robot);
  throw input_error(path, "not a recorded sweep (a ScanLog, a ROS 1 bag or a ROS 2 sqlite3 bag)");
}

std::unique_ptr<ScanSource> make_scan_source(const std::string& spec, const RobotModel& robot,
                                             const SimScanInputs& sim) {
  if (spec == "sim") return std::make_unique<SimSource>(sim);
  if (spec.rfind("log:", 0) == 0) {
    const std::string path = spec.substr(4);
    if (path.empty()) throw InputError("--source log:FILE needs a file");
    if (!std::filesystem::exists(path)) throw input_error(path, "no such file or directory");
    return std::make_unique<LogSource>(path, robot);
  }
  if (spec.rfind("lidar:", 0) == 0)
    throw InputError(
        "--source " + spec +
        ": the live RPLIDAR source is not built yet (hardware-in-the-loop issue); record a sweep and "
        "use log:FILE");
  throw InputError("--source '" + spec + "': not sim, log:FILE or lidar:DEV");
}

}  // namespace weldtwin
