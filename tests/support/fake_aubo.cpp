#include "tests/support/fake_aubo.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "hw/robot_driver.hpp"

namespace weldtwin::test {

using nlohmann::json;

FakeAubo::FakeAubo(FakeAuboSetting setting)
    : set_(std::move(setting)), q_(set_.start_q), qd_(JointVector::Zero()) {
  rpc_thread_ = std::thread([this] { serve_rpc(); });
  rtde_thread_ = std::thread([this] { serve_rtde(); });
}

FakeAubo::~FakeAubo() {
  quit_ = true;
  rpc_thread_.join();
  rtde_thread_.join();
}

std::string FakeAubo::spec() const {
  return "aubo://127.0.0.1:" + std::to_string(rpc_port()) + ":" + std::to_string(rtde_port());
}

std::vector<JointVector> FakeAubo::path() const {
  std::lock_guard<std::mutex> l(m_);
  return buffer_;
}
double FakeAubo::path_dt() const {
  std::lock_guard<std::mutex> l(m_);
  return dt_;
}
double FakeAubo::speed_fraction() const {
  std::lock_guard<std::mutex> l(m_);
  return speed_;
}
std::vector<std::string> FakeAubo::methods() const {
  std::lock_guard<std::mutex> l(m_);
  return methods_;
}
std::vector<std::string> FakeAubo::protocol_errors() const {
  std::lock_guard<std::mutex> l(m_);
  return errors_;
}
int FakeAubo::stops() const {
  std::lock_guard<std::mutex> l(m_);
  return stops_;
}
int FakeAubo::refused_logins() const {
  std::lock_guard<std::mutex> l(m_);
  return refused_logins_;
}
bool FakeAubo::moving() const {
  std::lock_guard<std::mutex> l(m_);
  const_cast<FakeAubo*>(this)->advance(host_seconds());
  return moving_;
}
double FakeAubo::progress() const {
  std::lock_guard<std::mutex> l(m_);
  return progress_;
}
JointVector FakeAubo::q() const {
  std::lock_guard<std::mutex> l(m_);
  return q_;
}

// The arm along the running path, at the wall-clock time `now_s` (under m_).
void FakeAubo::advance(double now_s) {
  if (!moving_) return;
  const double n = static_cast<double>(buffer_.size() - 1);
  const double rate = set_.time_scale * speed_ / dt_;  // path samples per second
  const double pos = std::min(n, (now_s - move_start_s_) * rate);
  const double frac = n > 0 ? pos / n : 1.0;
  auto hits = [&](double& at) {
    if (at < 0 || frac < at) return false;
    at = -1.0;  // once
    return true;
  };
  const size_t i = std::min(static_cast<size_t>(pos), buffer_.size() - 1);
  const size_t j = std::min(i + 1, buffer_.size() - 1);
  const double a = pos - static_cast<double>(i);
  q_ = (1.0 - a) * buffer_[i] + a * buffer_[j];
  qd_ = (buffer_[j] - buffer_[i]) * rate;
  progress_ = frac;
  if (hits(set_.drop_rpc_at)) drop_rpc_now_ = true;
  if (hits(set_.drop_rtde_at)) drop_rtde_now_ = true;
  if (hits(set_.mute_at)) mute_rpc_now_ = mute_rtde_now_ = true;
  if (hits(set_.garbage_rpc_at)) garbage_rpc_now_ = true;
  if (hits(set_.garbage_rtde_at)) garbage_rtde_now_ = true;
  if (hits(set_.fault_at)) {
    safety_ = "ProtectiveStop";
    moving_ = false;
    qd_.setZero();
  }
  if (pos >= n) {
    moving_ = false;
    qd_.setZero();
  }
}

std::string FakeAubo::handle(const std::string& text, bool& logged_in, bool& drop) {
  std::lock_guard<std::mutex> l(m_);
  advance(host_seconds());
  const json req = json::parse(text, nullptr, false);
  json id = nullptr;
  auto fail = [&](int code, const std::string& message, bool protocol) {
    if (protocol) errors_.push_back(message);
    return json{{"jsonrpc", "2.0"}, {"error", {{"code", code}, {"message", message}}}, {"id", id}}.dump();
  };
  auto ok = [&](const json& result) {
    return json{{"jsonrpc", "2.0"}, {"result", result}, {"id", id}}.dump();
  };
  if (req.is_discarded() || !req.is_object() || req.value("jsonrpc", "") != "2.0" || !req.contains("id") ||
      !req.contains("method") || !req["method"].is_string())
    return fail(-32600, "invalid request: " + text.substr(0, 80), true);
  id = req["id"];
  const std::string method = req["method"];
  const json p = req.value("params", json::array());
  methods_.push_back(method);
  if (!p.is_array()) return fail(-32602, method + ": params are not an array", true);
  if (method == "login") {
    if (p.size() == 2 && p[0] == set_.user && p[1] == set_.password) {
      logged_in = true;
      return ok(0);
    }
    ++refused_logins_;
    return fail(-32001, "login refused: wrong user or password", false);
  }
  if (!logged_in) return fail(-32002, method + " before login", true);
  if (method == "logout") {
    logged_in = false;
    drop = true;
    return ok(0);
  }
  if (method == "rob1.RobotState.getRobotModeType") return ok(set_.robot_mode);
  if (method == "rob1.RobotState.getSafetyModeType") return ok(safety_);
  if (method == "rob1.RobotState.getJointPositions") return ok(std::vector<double>(q_.data(), q_.data() + 6));
  if (method == "rob1.MotionControl.getExecId") return ok(moving_ ? exec_id_ : -1);
  if (method == "rob1.MotionControl.stopJoint") {
    ++stops_;
    moving_ = false;
    qd_.setZero();
    return ok(0);
  }
  if (method == "rob1.MotionControl.setSpeedFraction") {
    if (p.size() != 1 || !p[0].is_number() || !(p[0].get<double>() > 0 && p[0].get<double>() <= 1))
      return fail(-32602, "setSpeedFraction: not in (0, 1]", true);
    speed_ = p[0];
    return ok(0);
  }
  if (method.rfind("rob1.MotionControl.pathBuffer", 0) == 0 ||
      method == "rob1.MotionControl.movePathBuffer") {
    if (p.empty() || p[0] != "weldtwin") return fail(-32602, method + ": unknown buffer name", true);
    const std::string m = method.substr(method.rfind('.') + 1);
    if (m == "pathBufferFree") {
      if (!allocated_) return fail(-1, "no such buffer", false);
      allocated_ = evaluated_ = false;
      return ok(0);
    }
    if (m == "pathBufferAlloc") {
      if (moving_) return fail(-1, "pathBufferAlloc while moving", true);
      if (p.size() != 3 || p[1] != 2 || !p[2].is_number_integer() || p[2].get<int>() <= 0)
        return fail(-32602, "pathBufferAlloc: want [name, 2, size > 0]", true);
      buffer_.clear();
      buffer_size_ = p[2];
      allocated_ = true;
      evaluated_ = false;
      return ok(0);
    }
    if (!allocated_) return fail(-1, m + " before pathBufferAlloc", true);
    if (m == "pathBufferAppend") {
      if (p.size() != 2 || !p[1].is_array())
        return fail(-32602, "pathBufferAppend: want [name, points]", true);
      for (const json& w : p[1]) {
        if (!w.is_array() || w.size() != 6)
          return fail(-32602, "pathBufferAppend: a point is not 6 joints", true);
        JointVector q;
        for (int k = 0; k < 6; ++k) {
          if (!w[k].is_number() || !std::isfinite(w[k].get<double>()))
            return fail(-32602, "pathBufferAppend: a joint is not a finite number", true);
          q[k] = w[k];
        }
        if (buffer_.size() >= buffer_size_)
          return fail(-32602, "pathBufferAppend: more points than allocated", true);
        buffer_.push_back(q);
      }
      return ok(0);
    }
    if (m == "pathBufferEval") {
      if (buffer_.size() != buffer_size_) return fail(-1, "pathBufferEval: the buffer is not full", true);
      if (p.size() != 4 || !p[3].is_number() || !(p[3].get<double>() > 0))
        return fail(-32602, "pathBufferEval: want [name, a, v, interval > 0]", true);
      dt_ = p[3];
      evaluated_ = true;
      return ok(0);
    }
    if (m == "pathBufferValid") return ok(evaluated_);
    if (m == "movePathBuffer") {
      if (!evaluated_) return fail(-1, "movePathBuffer before the path was evaluated", true);
      if (moving_) return fail(-1, "movePathBuffer while moving", true);
      if (safety_ != "Normal") return fail(-1, "movePathBuffer in safety mode " + safety_, false);
      if ((q_ - buffer_.front()).cwiseAbs().maxCoeff() > 1e-3)
        return fail(-1, "movePathBuffer: the arm is not at the path's start", true);
      moving_ = true;
      move_start_s_ = host_seconds();
      progress_ = 0.0;
      return ok(++exec_id_);
    }
  }
  return fail(-32601, "method not found: " + method, true);
}

void FakeAubo::serve_rpc() {
  while (!quit_) {
    std::optional<JsonLink> client = rpc_.accept(0.05);
    if (!client) continue;
    bool logged_in = false, stalled = false;
    try {
      while (!quit_) {
        bool garbage = false;
        {
          std::lock_guard<std::mutex> l(m_);
          advance(host_seconds());
          if (drop_rpc_now_) {
            drop_rpc_now_ = false;
            break;
          }
          if (mute_rpc_now_) stalled = true, mute_rpc_now_ = false;
          garbage = garbage_rpc_now_;
        }
        const std::optional<std::string> text = client->receive(0.01);
        if (!text || set_.mute || stalled) continue;
        bool drop = false;
        const std::string answer = handle(*text, logged_in, drop);
        if (garbage) {
          std::lock_guard<std::mutex> l(m_);
          garbage_rpc_now_ = false;
        }
        client->send(garbage ? set_.garbage : answer);
        if (drop) break;
      }
    } catch (const LinkError&) {  // the client left
    }
  }
}

void FakeAubo::serve_rtde() {
  while (!quit_) {
    std::optional<JsonLink> client = rtde_.accept(0.05);
    if (!client) continue;
    bool stalled = false;
    try {
      // The subscription.
      std::optional<std::string> text;
      for (int k = 0; k < 100 && !text && !quit_; ++k) text = client->receive(0.01);
      if (!text || set_.mute) {
        while (!quit_ && set_.mute) client->receive(0.05);
        continue;
      }
      const json sub = json::parse(*text, nullptr, false);
      const bool good =
          !sub.is_discarded() && sub.value("method", "") == "subscribe" && sub.contains("params") &&
          sub["params"].value("fields", json::array()).dump().find("R1_actual_q") != std::string::npos;
      if (!good) {
        std::lock_guard<std::mutex> l(m_);
        errors_.push_back("bad RTDE subscription: " + text->substr(0, 80));
        client->send(json{{"jsonrpc", "2.0"},
                          {"error", {{"code", -32602}, {"message", "bad subscription"}}},
                          {"id", sub.is_discarded() ? json(nullptr) : sub.value("id", json(nullptr))}}
                         .dump());
        continue;
      }
      client->send(json{{"jsonrpc", "2.0"}, {"result", 0}, {"id", sub["id"]}}.dump());
      for (double next = host_seconds(); !quit_; next += 0.005) {
        std::this_thread::sleep_for(std::chrono::duration<double>(std::max(0.0, next - host_seconds())));
        json frame;
        bool garbage = false;
        {
          std::lock_guard<std::mutex> l(m_);
          advance(host_seconds());
          if (drop_rtde_now_) {
            drop_rtde_now_ = false;
            break;
          }
          if (mute_rtde_now_) {
            mute_rtde_now_ = false;
            stalled = true;
          }
          garbage = garbage_rtde_now_;
          garbage_rtde_now_ = false;
          frame = {{"timestamp", host_seconds()},
                   {"R1_actual_q", std::vector<double>(q_.data(), q_.data() + 6)},
                   {"R1_actual_qd", std::vector<double>(qd_.data(), qd_.data() + 6)},
                   {"R1_robot_mode", set_.robot_mode},
                   {"R1_safety_mode", safety_}};
        }
        if (stalled) {  // open and silent until the client leaves
          client->receive(0.05);
          continue;
        }
        client->send(garbage ? set_.garbage : frame.dump(), 0.5);
      }
    } catch (const LinkError&) {  // the client left
    }
  }
}

}  // namespace weldtwin::test
