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
std::vector<std::string> FakeAubo::requests() const {
  std::lock_guard<std::mutex> l(m_);
  return requests_;
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

std::string FakeAubo::handle(const std::string& text, bool& logged_in) {
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
  requests_.push_back(text);
  if (!p.is_array()) return fail(-32602, method + ": params are not an array", true);
  if (method == "__login__") {
    if (p.size() == 2 && p[0] == set_.user && p[1] == set_.password) {
      logged_in = true;
      return ok(0);
    }
    ++refused_logins_;
    return fail(-32001, "login refused: wrong user or password", false);
  }
  if (!logged_in) return fail(-32002, method + " before login", true);
  if (method == "getRobotNames") return ok(json::array({"rob1"}));
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
    if (p.empty() || !p[0].is_string()) return fail(-32602, method + ": no buffer name", true);
    const std::string m = method.substr(method.rfind('.') + 1);
    const bool known = allocated_ && p[0] == buffer_name_;
    if (m == "pathBufferFree") {
      if (!known) return ok(-5);  // the vendor's code for a buffer that does not exist
      allocated_ = evaluated_ = false;
      return ok(0);
    }
    if (m == "pathBufferAlloc") {
      if (moving_) return fail(-1, "pathBufferAlloc while moving", true);
      if (p.size() != 3 || p[1] != 2 || !p[2].is_number_integer() || p[2].get<int>() <= 0)
        return fail(-32602, "pathBufferAlloc: want [name, 2, size > 0]", true);
      buffer_.clear();
      buffer_name_ = p[0];
      buffer_size_ = p[2];
      allocated_ = true;
      evaluated_ = false;
      return ok(0);
    }
    if (m == "pathBufferValid" && !known) return ok(false);  // as the vendor's example: not valid
    if (!known) return fail(-1, m + ": no buffer of that name (before pathBufferAlloc?)", true);
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
      if (buffer_.empty()) return fail(-1, "pathBufferEval: the buffer is empty", true);
      auto six_positive = [](const json& v) {
        if (!v.is_array() || v.size() != 6) return false;
        for (const json& x : v)
          if (!x.is_number() || !(x.get<double>() > 0) || !std::isfinite(x.get<double>())) return false;
        return true;
      };
      if (p.size() != 4 || !six_positive(p[1]) || !six_positive(p[2]) || !p[3].is_number() ||
          !(p[3].get<double>() > 0))
        return fail(-32602, "pathBufferEval: want [name, 6 accelerations, 6 velocities, interval > 0]", true);
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
      ++exec_id_;
      return ok(0);
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
        const std::string answer = handle(*text, logged_in);
        if (garbage) {
          std::lock_guard<std::mutex> l(m_);
          garbage_rpc_now_ = false;
        }
        if (garbage)
          client->send_raw(set_.garbage);
        else
          client->send(answer);
      }
    } catch (const LinkError&) {  // the client left
    }
  }
}

namespace {

std::string msgpack(const json& j) {
  const std::vector<std::uint8_t> b = json::to_msgpack(j);
  return std::string(b.begin(), b.end());
}

}  // namespace

// RTDE as the vendor's codec frames it: SOF frames of MessagePack. The subscription must be
// [100, {"chanel": c, "frequency": f, "segments": [...], "to_server": false, "trigger": 0}] naming the four
// segments this fake streams, in their order; its answer is [100, c]; each frame [c, q, qd, mode, safety].
void FakeAubo::serve_rtde() {
  const json segments = {"R1_actual_q", "R1_actual_qd", "R1_robot_mode", "R1_safety_mode"};
  while (!quit_) {
    std::optional<JsonLink> client = rtde_.accept(0.05, Framing::kSofFrames);
    if (!client) continue;
    bool stalled = false;
    try {
      // The subscription.
      std::optional<std::string> payload;
      for (int k = 0; k < 100 && !payload && !quit_; ++k) payload = client->receive(0.01);
      if (!payload || set_.mute) {
        while (!quit_ && set_.mute) client->receive(0.05);
        continue;
      }
      const json sub = json::from_msgpack(*payload, true, false);
      const json recipe = !sub.is_discarded() && sub.is_array() && sub.size() == 2 ? sub[1] : json();
      const bool good = sub.is_array() && sub.size() == 2 && sub[0] == 100 && recipe.is_object() &&
                        recipe.size() == 5 && recipe.value("segments", json()) == segments &&
                        recipe.value("chanel", json()).is_number_integer() &&
                        recipe.value("frequency", json()).is_number() &&
                        recipe.value("to_server", true) == false && recipe.value("trigger", json()) == 0;
      if (!good) {
        std::lock_guard<std::mutex> l(m_);
        errors_.push_back("bad RTDE subscription: " + payload->substr(0, 80));
        client->send(msgpack(json::array({100, -1})));
        continue;
      }
      const int channel = recipe["chanel"];
      client->send(msgpack(json::array({100, channel})));
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
          frame = json::array({channel, std::vector<double>(q_.data(), q_.data() + 6),
                               std::vector<double>(qd_.data(), qd_.data() + 6), set_.robot_mode, safety_});
        }
        if (stalled) {  // open and silent until the client leaves
          client->receive(0.05);
          continue;
        }
        // Garbage goes out framed, as a frame whose payload was corrupted.
        client->send(garbage ? set_.garbage.substr(0, SofFramer::kMaxPayloadBytes) : msgpack(frame), 0.5);
      }
    } catch (const LinkError&) {  // the client left
    }
  }
}

}  // namespace weldtwin::test
