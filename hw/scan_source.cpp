#include "hw/scan_source.hpp"

#include <filesystem>
#include <fstream>

#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <thread>

#include "core/error.hpp"
#include "core/files.hpp"
#include "hw/robot_driver.hpp"
#include "hw/ros_bags.hpp"
#include "hw/rplidar.hpp"

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

/// A live RPLIDAR on the arm: the device scans in a thread while the driver runs the sweep program; the
/// turns that lie wholly within the joint states' time span make the log.
class LidarSource : public ScanSource {
 public:
  LidarSource(std::string port, const RobotModel& robot, const LiveScanInputs& live)
      : port_(std::move(port)), robot_(robot), live_(live) {}
  std::string describe() const override { return "the RPLIDAR on " + port_; }
  ScanLog acquire() override {
    RplidarDevice device(port_, live_.timeout_s);
    device.check_health();
    device.set_motor_pwm(rplidar::kDefaultPwm);
    std::this_thread::sleep_for(std::chrono::duration<double>(live_.spinup_s));
    // The sweep program at the plan's 200 Hz.
    JointTrajectory sweep;
    const double duration = live_.program->duration_s();
    const size_t n = static_cast<size_t>(std::ceil(duration / sweep.dt_s));
    for (size_t i = 0; i <= n; ++i)
      sweep.q.push_back(live_.program->q(std::min(duration, sweep.dt_s * static_cast<double>(i))));

    ScanLog scans;
    std::atomic<bool> done{false};
    std::exception_ptr lidar_failed;
    const double t0 = host_seconds();
    std::thread reader([&] {
      try {
        device.read_turns(live_.express, std::numeric_limits<int>::max(), scans, t0, &done);
      } catch (...) {
        lidar_failed = std::current_exception();
      }
    });
    std::vector<JointState> joints;
    try {
      live_.driver->execute(sweep, [&](double host_s, const JointState& js) {
        JointState j = js;
        j.t_s = host_s - t0;
        if (joints.empty() || j.t_s > joints.back().t_s) joints.push_back(j);
      });
    } catch (...) {
      done = true;
      reader.join();
      throw;
    }
    done = true;
    reader.join();
    if (lidar_failed) std::rethrow_exception(lidar_failed);
    if (joints.size() < 2) throw input_error(live_.driver->describe(), "no joint states during the sweep");

    // One log on the host's clock, from the first joint state on; turns outside the joints' span dropped.
    ScanLog log;
    log.source = "cell";
    log.robot = robot_.name();
    log.joint_names = robot_.joint_names();
    const double start = joints.front().t_s, end = joints.back().t_s;
    for (JointState& j : joints) {
      j.t_s -= start;
      log.joints.push_back(j);
    }
    for (const LidarTurn& turn : scans.turns) {
      if (turn.count == 0) continue;
      const double first = scans.samples[turn.first].t_s,
                   last = scans.samples[turn.first + turn.count - 1].t_s;
      if (first < start || last > end) continue;
      LidarTurn t = turn;
      t.t_start_s -= start;
      t.first = static_cast<uint32_t>(log.samples.size());
      log.turns.push_back(t);
      for (uint32_t k = 0; k < turn.count; ++k) {
        LidarSample s = scans.samples[turn.first + k];
        s.t_s -= start;
        log.samples.push_back(s);
      }
    }
    if (log.turns.empty()) throw input_error(port_, "no whole LiDAR turn during the sweep");
    return log;
  }

 private:
  std::string port_;
  const RobotModel& robot_;
  LiveScanInputs live_;
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
  // Any version: the reader says which it is, if not 2.0.
  if (magic.rfind("#ROSBAG V", 0) == 0 || magic.rfind("#ROSRECORD V", 0) == 0)
    return read_ros1_bag(path, robot);
  if (magic.rfind("SQLite format 3", 0) == 0 || magic.rfind("\x89MCAP", 0) == 0)
    return read_ros2_bag(path, robot);
  throw input_error(path, "not a recorded sweep (a ScanLog, a ROS 1 bag or a ROS 2 bag: sqlite3 or MCAP)");
}

std::unique_ptr<ScanSource> make_scan_source(const std::string& spec, const RobotModel& robot,
                                             const SimScanInputs& sim, const LiveScanInputs& live) {
  if (spec == "sim") return std::make_unique<SimSource>(sim);
  if (spec.rfind("log:", 0) == 0) {
    const std::string path = spec.substr(4);
    if (path.empty()) throw InputError("--source log:FILE needs a file");
    if (!path_exists(path)) throw input_error(path, "no such file or directory");
    return std::make_unique<LogSource>(path, robot);
  }
  if (spec.rfind("lidar:", 0) == 0) {
    const std::string port = spec.substr(6);
    if (port.empty()) throw InputError("--source lidar:DEV needs a serial port (lidar:/dev/ttyUSB0)");
    if (!live.driver || !live.program)
      throw InputError("--source " + spec + ": a live sweep needs the arm that carries the LiDAR (--robot)");
    return std::make_unique<LidarSource>(port, robot, live);
  }
  throw InputError("--source '" + spec + "': not sim, log:FILE or lidar:DEV");
}

}  // namespace weldtwin
