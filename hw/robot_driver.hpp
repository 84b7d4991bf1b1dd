// Where a joint trajectory is executed, behind one interface:
//   sim            the twin: the trajectory run by MuJoCo's position servos (sim/replay), contacts fail it;
//   aubo://HOST    an Aubo i5 on its ARCS controller: commands as JSON-RPC 2.0 on TCP port 30004 (log in,
//                  load the 200 Hz joint trajectory into a path buffer, run it, stop), the arm's state from
//                  the RTDE service on port 30010 (joint positions and velocities, robot and safety mode).
//                  `aubo://HOST:RPC_PORT:RTDE_PORT` names other ports (the tests' fake controller).
// A driver never leaves the arm moving on an error: a fault, a dropped connection, a timeout or a stop
// request (SIGINT) sends a stop, waits for the arm to halt, and is reported as one RobotError line.
// docs/hardware.md lists the exchanges.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "core/scan_log.hpp"

namespace weldtwin {

class MujocoWorld;
struct PartSpec;
struct Mesh;

/// What the `sim` driver runs in: the twin, and the part where it truly stands (contacts and the arm's
/// clearance to the part are watched as in the replay).
struct SimRobotInputs {
  const MujocoWorld* world = nullptr;
  const PartSpec* part = nullptr;
  const Mesh* mesh = nullptr;
  Iso3 T_base_part = Iso3::Identity();
};

/// Joint positions at equal time steps: what is sent to the robot.
struct JointTrajectory {
  double dt_s = 0.005;  ///< 200 Hz, as plans are sampled
  std::vector<JointVector> q;
  double duration_s() const { return q.empty() ? 0.0 : dt_s * static_cast<double>(q.size() - 1); }
};

struct RobotDriverSetting {
  double timeout_s = 2.0;             ///< every exchange with the controller
  double speed_fraction = 1.0;        ///< speed override (0, 1]: the trajectory runs this much slower in time
  double start_tolerance_rad = 0.01;  ///< the arm must stand this close to the trajectory's first sample
  std::string user = "aubo", password = "123456";  ///< controller login (ARCS factory defaults)
  /// Set (by a SIGINT handler) to stop the arm; checked every state frame.
  const std::atomic<bool>* stop_request = nullptr;
  /// Real time: a sim driver paces itself to the wall clock (when a live LiDAR scans along).
  bool realtime = false;
};

/// What happened while a trajectory ran.
struct ExecutionLog {
  std::vector<JointState> joints;  ///< the arm's joint positions as reported, times from the start [s]
  size_t samples_sent = 0;
  double wall_s = 0.0;
  std::vector<std::string> exchanges;  ///< every command sent, in order (method names), for the record
};

/// The robot failed or was stopped while executing (fault, dropped connection, timeout, SIGINT). The arm has
/// been stopped (as far as the controller could be reached; the message says if not). It carries what was
/// recorded up to then (commands sent, joint states seen), so that a failed run's record loses nothing.
class RobotError : public std::runtime_error {
 public:
  explicit RobotError(const std::string& what, ExecutionLog log = {})
      : std::runtime_error(what), log_(std::move(log)) {}
  const ExecutionLog& log() const { return log_; }

 private:
  ExecutionLog log_;
};

class RobotDriver {
 public:
  virtual ~RobotDriver() = default;
  /// "the twin (MuJoCo)", "aubo://10.0.0.2": for progress lines and reports.
  virtual std::string describe() const = 0;
  /// Connects (and logs in) and checks the arm is ready: powered, running, no safety stop. Throws InputError
  /// for an unreachable controller or a refused login, RobotError for an arm not ready.
  virtual void connect() = 0;
  /// The arm's joint positions now.
  virtual JointVector joint_positions() = 0;
  /// Executes `trajectory` (which must start where the arm stands) and returns the joint states recorded on
  /// the way, times from its start. `on_state` (may be empty) sees every state as it arrives, with the host's
  /// steady-clock time in seconds. Throws RobotError having stopped the arm.
  virtual ExecutionLog execute(
      const JointTrajectory& trajectory,
      const std::function<void(double host_s, const JointState&)>& on_state = {}) = 0;
  /// The exchanges a dry run would make for `trajectory`, as JSON text (nothing is sent).
  virtual std::string dry_run(const JointTrajectory& trajectory) const = 0;
};

/// The driver named by `spec` (sim | aubo://HOST[:RPC_PORT[:RTDE_PORT]]). `sim` is the twin the sim driver
/// runs in (its pointers must outlive the driver). Throws InputError for an unknown or malformed spec.
std::unique_ptr<RobotDriver> make_robot_driver(const std::string& spec, const RobotModel& robot,
                                               const SimRobotInputs& sim, const RobotDriverSetting& setting);

/// The Aubo driver (hw/aubo_driver.cpp).
std::unique_ptr<RobotDriver> make_aubo_driver(const std::string& host, int rpc_port, int rtde_port,
                                              const RobotModel& robot, const RobotDriverSetting& setting);

/// The host's steady clock [s] (the time base of live LiDAR samples and robot states).
double host_seconds();

}  // namespace weldtwin
