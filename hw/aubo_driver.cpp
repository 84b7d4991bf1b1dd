// The Aubo i5 on its ARCS controller. Method names, positional parameters and result codes follow the
// vendor's own JSON-RPC examples (port 30004: `getRobotNames`, `<robot>.RobotState.*`,
// `<robot>.MotionControl.*`); the state stream follows the vendor's RTDE codec (port 30010: SOF frames, the
// segments `R1_actual_q`, `R1_actual_qd`, `R1_robot_mode`, `R1_safety_mode`). docs/hardware.md lists every
// exchange and says which forms are inferred rather than seen in the vendor's examples.
//
// A trajectory goes to the controller as a path buffer of joint waypoints at the plan's 200 Hz step (buffer
// type 2: waypoints at a fixed time interval), is checked by the controller against the robot's joint limits
// (pathBufferEval, pathBufferValid), then run (movePathBuffer) while the RTDE stream is watched. Any fault,
// silence, dropped connection, overrun or stop request ends in stopJoint and a wait for the arm to halt.
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/error.hpp"
#include "hw/aubo_protocol.hpp"
#include "hw/json_link.hpp"
#include "hw/robot_driver.hpp"

namespace weldtwin {
namespace {

using nlohmann::json;

constexpr const char* kBuffer = "weldtwin";
constexpr int kBufferType = 2;                 // joint waypoints at a fixed time interval
constexpr size_t kAppendChunk = 200;           // waypoints per pathBufferAppend (1 s of plan)
constexpr double kStopAcceleration = 3;        // [rad/s^2] stopJoint: a controlled stop
constexpr double kHaltedVelocity = 1e-3;       // [rad/s] every joint slower than this: the arm stands
constexpr double kSilentStream_s = 0.1;        // [s] no state frame for this long: ask the motion id instead
constexpr double kStateRate_hz = 200;          // the RTDE subscription's frequency
constexpr int kStateChannel = 0;               // the RTDE channel we subscribe on
constexpr int kNoBuffer = -5;                  // pathBufferFree's code for a buffer that does not exist
constexpr const char* kLogin = "__login__";    // the SDK's login method (docs/hardware.md: inferred)
constexpr const char* kDefaultRobot = "rob1";  // the robot's name until getRobotNames says otherwise

class RpcChannel {
 public:
  explicit RpcChannel(double timeout_s) : timeout_s_(timeout_s) {}
  void open(const std::string& host, int port) { link_ = JsonLink::connect(host, port, timeout_s_); }
  bool is_open() const { return link_.is_open(); }
  void close() { link_.close(); }

  /// Sends a request and waits for its answer. Throws Refused for an error answer, LinkError when the
  /// connection is gone or the answer does not come within the timeout.
  json call(const std::string& method, const json& params, double timeout_s = -1) {
    const int id = ++next_id_;
    link_.send(json{{"jsonrpc", "2.0"}, {"method", method}, {"params", params}, {"id", id}}.dump(),
               timeout_s_);
    const double wait = timeout_s > 0 ? timeout_s : timeout_s_;
    const double t0 = host_seconds();
    for (;;) {
      const double left = wait - (host_seconds() - t0);
      if (left <= 0) throw LinkError("no answer to " + method + " within " + seconds(wait));
      const std::optional<std::string> text = link_.receive(left);
      if (!text) continue;
      if (std::optional<json> result = aubo::parse_reply(*text, id, method)) return *result;
    }
  }
  static std::string seconds(double s) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f s", s);
    return b;
  }

 private:
  JsonLink link_;
  double timeout_s_;
  int next_id_ = 0;
};

json six(const JointVector& q) {
  return json::array({q[0], q[1], q[2], q[3], q[4], q[5]});
}

json waypoints(const JointTrajectory& t, size_t from, size_t to) {
  json a = json::array();
  for (size_t i = from; i < to; ++i) a.push_back(six(t.q[i]));
  return a;
}

/// The requests that load a trajectory, in order (methods without the robot's name): the path is evaluated
/// against the robot's joint acceleration and velocity limits.
std::vector<std::pair<std::string, json>> load_requests(const JointTrajectory& t, double speed_fraction,
                                                        const JointVector& max_acceleration,
                                                        const JointVector& max_velocity) {
  std::vector<std::pair<std::string, json>> r;
  r.emplace_back("MotionControl.setSpeedFraction", json::array({speed_fraction}));
  r.emplace_back("MotionControl.pathBufferAlloc", json::array({kBuffer, kBufferType, t.q.size()}));
  for (size_t i = 0; i < t.q.size(); i += kAppendChunk)
    r.emplace_back("MotionControl.pathBufferAppend",
                   json::array({kBuffer, waypoints(t, i, std::min(t.q.size(), i + kAppendChunk))}));
  r.emplace_back("MotionControl.pathBufferEval",
                 json::array({kBuffer, six(max_acceleration), six(max_velocity), t.dt_s}));
  return r;
}

class AuboDriver : public RobotDriver {
 public:
  AuboDriver(std::string host, int rpc_port, int rtde_port, const RobotModel& robot,
             const RobotDriverSetting& setting)
      : host_(std::move(host)),
        rpc_port_(rpc_port),
        rtde_port_(rtde_port),
        set_(setting),
        rpc_(setting.timeout_s),
        max_acceleration_(robot.max_acceleration()),
        max_velocity_(robot.max_velocity()) {
    if (robot.dof() != 6)
      throw InputError("aubo://: the robot model has " + std::to_string(robot.dof()) + " joints, not 6");
  }

  std::string describe() const override {
    std::string s = "aubo://" + host_;
    if (rpc_port_ != 30004 || rtde_port_ != 30010)
      s += ":" + std::to_string(rpc_port_) + ":" + std::to_string(rtde_port_);
    return s;
  }

  void connect() override {
    try {
      login();
    } catch (const LinkError& e) {
      throw InputError(describe() + ": cannot reach the controller's command port: " + e.what());
    } catch (const aubo::Refused& e) {
      throw InputError(describe() + ": " + e.what() + " (user '" + set_.user + "')");
    }
    std::string mode, safety;
    try {
      mode = call("RobotState.getRobotModeType", json::array()).get<std::string>();
      safety = call("RobotState.getSafetyModeType", json::array()).get<std::string>();
    } catch (const std::exception& e) {
      throw RobotError(describe() + ": cannot read the arm's mode: " + e.what());
    }
    if (mode != "Running")
      throw RobotError(describe() + ": the arm is not ready (robot mode " + mode +
                       "): power it on and release the brakes on the pendant");
    if (safety != "Normal")
      throw RobotError(describe() + ": the arm is in safety mode " + safety + ": clear it on the pendant");
    try {
      rtde_ = JsonLink::connect(host_, rtde_port_, set_.timeout_s, Framing::kSofFrames);
      rtde_.send(aubo::subscription(kStateChannel, kStateRate_hz), set_.timeout_s);
      if (!next_frame(set_.timeout_s))
        throw LinkError("no state frame within " + RpcChannel::seconds(set_.timeout_s));
    } catch (const LinkError& e) {
      throw InputError(describe() + ": the state stream (RTDE, port " + std::to_string(rtde_port_) +
                       "): " + e.what());
    }
  }

  JointVector joint_positions() override {
    try {
      return aubo::joint_vector(call("RobotState.getJointPositions", json::array()), "getJointPositions");
    } catch (const std::exception& e) {
      throw RobotError(describe() + ": cannot read the joint positions: " + e.what());
    }
  }

  std::string dry_run(const JointTrajectory& t) const override {
    json out = json::array();
    int id = 0;
    auto add = [&](const std::string& method, const json& params) {
      out.push_back({{"jsonrpc", "2.0"}, {"method", method}, {"params", params}, {"id", ++id}});
    };
    add(kLogin, json::array({set_.user, "***"}));
    add("getRobotNames", json::array());
    const std::string r = std::string(kDefaultRobot) + ".";
    for (const auto& [m, p] : load_requests(t, set_.speed_fraction, max_acceleration_, max_velocity_))
      add(r + m, p);
    add(r + "MotionControl.pathBufferValid", json::array({kBuffer}));
    add(r + "MotionControl.movePathBuffer", json::array({kBuffer}));
    json j;
    j["robot"] = describe();
    j["samples"] = t.q.size();
    j["dt_s"] = t.dt_s;
    j["duration_s"] = t.duration_s() / set_.speed_fraction;
    j["speed_fraction"] = set_.speed_fraction;
    j["requests"] = out;
    return j.dump(1);
  }

  ExecutionLog execute(const JointTrajectory& t,
                       const std::function<void(double, const JointState&)>& on_state) override {
    if (t.q.empty()) throw std::invalid_argument("an empty trajectory");
    ExecutionLog log;
    try {
      run(t, on_state, log);
    } catch (const RobotError& e) {
      throw RobotError(e.what(), std::move(log));
    } catch (const std::exception& e) {
      // Nothing else may leave the arm moving: whatever it was, the arm is stopped first.
      try {
        abort_motion(std::string("an unexpected error (") + e.what() + ")");
      } catch (const RobotError& stopped) {
        throw RobotError(stopped.what(), std::move(log));
      }
    }
    return log;
  }

 private:
  /// execute()'s work: `log` holds what was sent and seen, also when it throws.
  void run(const JointTrajectory& t, const std::function<void(double, const JointState&)>& on_state,
           ExecutionLog& log) {
    // Nothing moves unless the arm stands where the trajectory starts.
    if (!latest_frame(set_.timeout_s))
      throw RobotError(describe() + ": the state stream is silent; nothing was sent");
    const double off = (frame_.q - t.q.front()).cwiseAbs().maxCoeff();
    if (off > set_.start_tolerance_rad) {
      char b[200];
      std::snprintf(b, sizeof b, ": the arm stands %.3f rad from the trajectory's start; nothing was sent",
                    off);
      throw RobotError(describe() + b);
    }
    try {
      const json freed = call("MotionControl.pathBufferFree", json::array({kBuffer}));
      if (freed != kNoBuffer) aubo::expect_success(freed, "pathBufferFree");
      log.exchanges.push_back("pathBufferFree");
      for (const auto& [method, params] :
           load_requests(t, set_.speed_fraction, max_acceleration_, max_velocity_)) {
        aubo::expect_success(call(method, params), method);
        log.exchanges.push_back(method.substr(method.rfind('.') + 1));
      }
      log.samples_sent = t.q.size();
      // The controller checks the path (limits, timing) before it may run.
      const double t_valid = host_seconds();
      while (!call("MotionControl.pathBufferValid", json::array({kBuffer})).get<bool>()) {
        if (host_seconds() - t_valid > set_.timeout_s)
          throw aubo::Refused("the controller did not accept the path within " +
                              RpcChannel::seconds(set_.timeout_s));
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
      log.exchanges.push_back("pathBufferValid");
    } catch (const aubo::Refused& e) {
      free_buffer();
      throw RobotError(describe() + ": " + e.what() + "; the arm did not move");
    } catch (const LinkError& e) {
      throw RobotError(describe() + ": the command connection failed while loading the path (" + e.what() +
                       "); the arm did not move");
    } catch (const json::exception& e) {
      free_buffer();
      throw RobotError(describe() + ": a malformed answer while loading the path (" + e.what() +
                       "); the arm did not move");
    }

    // Run it, watching every state frame.
    const double t0 = host_seconds();
    const double budget = t.duration_s() / set_.speed_fraction + 2 * set_.timeout_s + 2.0;
    try {
      aubo::expect_success(call("MotionControl.movePathBuffer", json::array({kBuffer})), "movePathBuffer");
      log.exchanges.push_back("movePathBuffer");
    } catch (const std::exception& e) {
      abort_motion(std::string("movePathBuffer failed: ") + e.what());
    }
    // The controller's motion id: -1 until the path starts, the path's id while it runs, then another.
    int exec_id = -1;
    // Every state frame is kept, and shown to `on_state`.
    auto record = [&](double now) {
      JointState js;
      js.t_s = now - t0;
      js.q = frame_.q;
      if (log.joints.empty() || js.t_s > log.joints.back().t_s) log.joints.push_back(js);
      if (on_state) on_state(now, js);
    };
    double last_frame = host_seconds(), last_poll = 0.0;
    for (;;) {
      if (set_.stop_request && set_.stop_request->load()) abort_motion("stopped on request (SIGINT)");
      bool got = false;
      try {
        got = next_frame(0.02);
      } catch (const LinkError& e) {
        abort_motion(std::string("the state stream dropped: ") + e.what());
      }
      const double now = host_seconds();
      if (got) {
        last_frame = now;
        record(now);
        if (frame_.safety_mode != "Normal")
          abort_motion("controller fault: safety mode " + frame_.safety_mode);
        if (frame_.robot_mode != "Running") abort_motion("controller fault: robot mode " + frame_.robot_mode);
      } else if (now - last_frame > set_.timeout_s) {
        abort_motion("the state stream is silent for " + RpcChannel::seconds(now - last_frame));
      }
      if (now - t0 > budget) abort_motion("the path did not finish in " + RpcChannel::seconds(budget));
      if (now - last_poll > 0.05) {  // is the path still running?
        last_poll = now;
        int id = 0;
        try {
          id = call("MotionControl.getExecId", json::array()).get<int>();
        } catch (const std::exception& e) {
          abort_motion(std::string("the command connection failed: ") + e.what());
        }
        if (exec_id < 0 && id >= 0) exec_id = id;  // it started
        if (exec_id >= 0 && id != exec_id) break;  // it ended
        if (exec_id < 0 && now - t0 > set_.timeout_s) {
          // Never seen running: done if the arm already stands at the path's end, else it did not start.
          if ((frame_.q - t.q.back()).cwiseAbs().maxCoeff() <= set_.start_tolerance_rad &&
              frame_.qd.cwiseAbs().maxCoeff() < kHaltedVelocity)
            break;
          abort_motion("the controller did not start the path within " + RpcChannel::seconds(set_.timeout_s));
        }
      }
    }
    log.wall_s = host_seconds() - t0;
    free_buffer();
    // Where the arm came to rest (the frames may lag the controller's motion id by a period): every frame up
    // to the arm standing at the path's end is kept too.
    double end_off = 1e9;
    try {
      for (const double t_end = host_seconds(); host_seconds() - t_end < set_.timeout_s;) {
        if (!next_frame(0.02)) continue;
        record(host_seconds());
        // A fault that ended the path before its frame was read (the motion id changes with it).
        if (frame_.safety_mode != "Normal")
          abort_motion("controller fault: safety mode " + frame_.safety_mode);
        end_off = (frame_.q - t.q.back()).cwiseAbs().maxCoeff();
        if (end_off <= set_.start_tolerance_rad && frame_.qd.cwiseAbs().maxCoeff() < kHaltedVelocity) break;
      }
    } catch (const LinkError& e) {
      throw RobotError(describe() +
                       ": the path ran, but the state stream failed before the arm was seen at rest (" +
                       e.what() + ")");
    }
    if (end_off > set_.start_tolerance_rad) {
      char b[200];
      std::snprintf(b, sizeof b, "the path ended with the arm %.3f rad from its last sample", end_off);
      abort_motion(b);
    }
  }

  /// Opens the command connection, logs in and learns the robot's name (the prefix of its methods).
  void login() {
    rpc_.open(host_, rpc_port_);
    rpc_.call(kLogin, json::array({set_.user, set_.password}));
    const json names = rpc_.call("getRobotNames", json::array());
    if (!names.is_array() || names.empty() || !names[0].is_string() || names[0].get<std::string>().empty())
      throw LinkError("getRobotNames answered " + names.dump().substr(0, 80) + ", not a robot's name");
    robot_name_ = names[0].get<std::string>();
  }

  /// A method of the robot (`MotionControl.stopJoint` is sent as `rob1.MotionControl.stopJoint`).
  json call(const std::string& method, const json& params, double timeout_s = -1) {
    return rpc_.call(robot_name_ + "." + method, params, timeout_s);
  }

  /// Reads the next state frame into frame_ (false: none within the wait). Throws LinkError.
  bool next_frame(double wait_s) {
    for (;;) {
      const std::optional<std::string> text = rtde_.receive(wait_s);
      if (!text) return false;
      if (aubo::parse_state_frame(*text, frame_)) return true;
    }
  }

  /// The newest state frame (older ones queued since the last read are skipped).
  bool latest_frame(double wait_s) {
    if (!next_frame(wait_s)) return false;
    while (next_frame(0.0)) {
    }
    return true;
  }

  void free_buffer() {
    try {
      if (rpc_.is_open()) call("MotionControl.pathBufferFree", json::array({kBuffer}), 0.5);
    } catch (...) {  // best effort: the buffer is freed at the next run anyway
    }
  }

  /// Stops the arm (over a new connection when the old one is gone), waits for it to halt, and throws.
  [[noreturn]] void abort_motion(const std::string& why) {
    std::string stop_note;
    bool sent = false;
    for (int attempt = 0; attempt < 2 && !sent; ++attempt) {
      try {
        if (attempt == 1 || !rpc_.is_open()) {
          rpc_.close();
          login();
        }
        aubo::expect_success(call("MotionControl.stopJoint", json::array({kStopAcceleration})), "stopJoint");
        sent = true;
      } catch (const std::exception& e) {
        stop_note = e.what();
      }
    }
    if (!sent) {
      free_buffer();
      throw RobotError(describe() + ": " + why + "; COULD NOT SEND A STOP (" + stop_note +
                       "): stop the arm with the emergency stop");
    }
    // Wait for it to halt: the state stream's velocities, or the controller's motion id where the stream is
    // gone or silent.
    const double t0 = host_seconds();
    std::string halted = "not confirmed within " + RpcChannel::seconds(set_.timeout_s);
    int still = 0;
    double last_frame = t0;
    while (host_seconds() - t0 < set_.timeout_s) {
      bool got = false;
      try {
        got = rtde_.is_open() && next_frame(0.02);
      } catch (const LinkError&) {
        rtde_.close();
      }
      if (got) {
        last_frame = host_seconds();
        still = frame_.qd.cwiseAbs().maxCoeff() < kHaltedVelocity ? still + 1 : 0;
        if (still >= 3) {
          halted = "the arm halted";
          break;
        }
      } else if (!rtde_.is_open() || host_seconds() - last_frame > kSilentStream_s) {
        try {
          if (call("MotionControl.getExecId", json::array()).get<int>() < 0) {
            halted = "the controller reports no motion";
            break;
          }
        } catch (const std::exception&) {
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    free_buffer();
    throw RobotError(describe() + ": " + why + "; stop sent, " + halted);
  }

  std::string host_;
  int rpc_port_, rtde_port_;
  RobotDriverSetting set_;
  RpcChannel rpc_;
  JointVector max_acceleration_,
      max_velocity_;  // [rad/s^2], [rad/s]: the controller checks the path with them
  std::string robot_name_ = kDefaultRobot;
  JsonLink rtde_;
  aubo::StateFrame frame_;
};

}  // namespace

std::unique_ptr<RobotDriver> make_aubo_driver(const std::string& host, int rpc_port, int rtde_port,
                                              const RobotModel& robot, const RobotDriverSetting& setting) {
  return std::make_unique<AuboDriver>(host, rpc_port, rtde_port, robot, setting);
}

}  // namespace weldtwin
