#include "hw/robot_driver.hpp"

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/error.hpp"
#include "sim/replay.hpp"

namespace weldtwin {

double host_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

namespace {

/// The trajectory run `fraction` times as fast (slower for fraction < 1), resampled at its own step.
JointTrajectory slowed(const JointTrajectory& t, double fraction) {
  if (fraction >= 1.0 || t.q.size() < 2) return t;
  JointTrajectory out;
  out.dt_s = t.dt_s;
  const double last = static_cast<double>(t.q.size() - 1);
  const size_t n = static_cast<size_t>(std::ceil(last / fraction)) + 1;
  for (size_t k = 0; k < n; ++k) {
    const double u = std::min(last, static_cast<double>(k) * fraction);
    const size_t i = std::min(static_cast<size_t>(u), t.q.size() - 2);
    const double a = u - static_cast<double>(i);
    out.q.push_back((1.0 - a) * t.q[i] + a * t.q[i + 1]);
  }
  return out;
}

/// The twin as the robot: the trajectory executed by MuJoCo's servos, contacts and the arm's clearance to the
/// part watched as in the replay.
class SimDriver : public RobotDriver {
 public:
  SimDriver(const RobotModel& robot, const SimRobotInputs& sim, const RobotDriverSetting& setting)
      : robot_(robot), sim_(sim), set_(setting) {
    if (!sim_.world || !sim_.part || !sim_.mesh) throw std::logic_error("sim robot driver without a twin");
  }
  std::string describe() const override { return "the twin (MuJoCo)"; }
  void connect() override {}
  JointVector joint_positions() override { return q_; }

  ExecutionLog execute(const JointTrajectory& trajectory,
                       const std::function<void(double, const JointState&)>& on_state) override {
    if (trajectory.q.empty()) throw std::invalid_argument("an empty trajectory");
    if (placed_ && (trajectory.q.front() - q_).cwiseAbs().maxCoeff() > set_.start_tolerance_rad)
      throw RobotError("the twin's arm is not at the trajectory's start");
    const JointTrajectory run = slowed(trajectory, set_.speed_fraction);
    WeldPlan plan;
    for (size_t i = 0; i < run.q.size(); ++i) {
      PlanSample s;
      s.t_s = run.dt_s * static_cast<double>(i);
      s.q = run.q[i];
      s.T_base_tcp = robot_.forward_kinematics(s.q, tcp_link_);
      plan.samples.push_back(s);
    }
    const ReplayResult replay =
        replay_plan(*sim_.world, robot_, plan, *sim_.part, *sim_.mesh, sim_.T_base_part);
    ExecutionLog log;
    log.samples_sent = trajectory.q.size();
    log.exchanges = {"twin: execute " + std::to_string(run.q.size()) + " samples"};
    const double t0 = host_seconds();
    for (const ReplaySample& r : replay.samples) {
      if (set_.stop_request && set_.stop_request->load()) {
        q_ = r.q;
        throw RobotError("stopped on request: the twin's arm halted at t = " + std::to_string(r.t_s) + " s");
      }
      JointState js;
      js.t_s = r.t_s;
      js.q = r.q;
      log.joints.push_back(js);
      if (set_.realtime)
        std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
            std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                std::chrono::duration<double>(t0 + r.t_s))));
      if (on_state) on_state(set_.realtime ? host_seconds() : t0 + r.t_s, js);
    }
    log.wall_s = host_seconds() - t0;
    q_ = replay.samples.back().q;
    placed_ = true;
    if (!replay.passed()) throw RobotError("the twin's arm failed: " + replay.failures.front());
    return log;
  }

  std::string dry_run(const JointTrajectory& trajectory) const override {
    nlohmann::json j;
    j["robot"] = "sim";
    j["samples"] = trajectory.q.size();
    j["dt_s"] = trajectory.dt_s;
    j["speed_fraction"] = set_.speed_fraction;
    return j.dump(1);
  }

 private:
  const RobotModel& robot_;
  SimRobotInputs sim_;
  RobotDriverSetting set_;
  int tcp_link_ = robot_.require_link("tcp");
  JointVector q_ = JointVector::Zero();
  bool placed_ = false;
};

int parse_port(const std::string& spec, const std::string& text) {
  try {
    size_t used = 0;
    const int p = std::stoi(text, &used);
    if (used == text.size() && p > 0 && p < 65536) return p;
  } catch (const std::exception&) {
  }
  throw InputError("--robot " + spec + ": '" + text + "' is not a port");
}

}  // namespace

std::unique_ptr<RobotDriver> make_robot_driver(const std::string& spec, const RobotModel& robot,
                                               const SimRobotInputs& sim, const RobotDriverSetting& setting) {
  if (!(setting.speed_fraction > 0.0 && setting.speed_fraction <= 1.0))
    throw InputError("--speed " + std::to_string(setting.speed_fraction) + ": must be in (0, 1]");
  if (spec == "sim") return std::make_unique<SimDriver>(robot, sim, setting);
  const std::string scheme = "aubo://";
  if (spec.rfind(scheme, 0) == 0) {
    std::string rest = spec.substr(scheme.size());
    while (!rest.empty() && rest.back() == '/') rest.pop_back();
    std::vector<std::string> parts;
    for (size_t a = 0, b; a <= rest.size(); a = b + 1) {
      b = rest.find(':', a);
      if (b == std::string::npos) b = rest.size();
      parts.push_back(rest.substr(a, b - a));
    }
    if (parts.empty() || parts[0].empty() || parts.size() > 3)
      throw InputError("--robot " + spec + ": not aubo://HOST[:RPC_PORT[:RTDE_PORT]]");
    const int rpc = parts.size() > 1 ? parse_port(spec, parts[1]) : 30004;
    const int rtde = parts.size() > 2 ? parse_port(spec, parts[2]) : 30010;
    return make_aubo_driver(parts[0], rpc, rtde, robot, setting);
  }
  throw InputError("--robot '" + spec + "': not sim or aubo://HOST");
}

}  // namespace weldtwin
