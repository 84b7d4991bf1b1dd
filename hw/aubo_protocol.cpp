#include "hw/aubo_protocol.hpp"

namespace weldtwin::aubo {

using nlohmann::json;

namespace {

/// A mode field of a state frame: a string, or a LinkError (a frame without it is malformed).
std::string mode_field(const json& frame, const char* key) {
  const auto it = frame.find(key);
  if (it == frame.end() || !it->is_string()) throw LinkError(std::string("malformed state frame: no ") + key);
  return it->get<std::string>();
}

}  // namespace

JointVector joint_vector(const json& a, const std::string& what) {
  if (!a.is_array() || a.size() != 6) throw LinkError(what + " is not six numbers");
  JointVector q;
  for (int i = 0; i < 6; ++i) {
    if (!a[i].is_number()) throw LinkError(what + " is not six numbers");
    q[i] = a[i].get<double>();
  }
  return q;
}

std::optional<json> parse_reply(const std::string& text, int id, const std::string& method) {
  json reply = json::parse(text, nullptr, false);
  if (reply.is_discarded() || !reply.is_object()) throw LinkError("the controller sent malformed JSON");
  const auto it = reply.find("id");
  if (it == reply.end() || *it != id) return std::nullopt;  // a notification, or a late answer
  if (const auto e = reply.find("error"); e != reply.end()) {
    const auto message = e->is_object() ? e->find("message") : e->end();
    const bool has_message = e->is_object() && message != e->end() && message->is_string();
    throw Refused(method + " refused: " + (has_message ? message->get<std::string>() : e->dump()));
  }
  const auto result = reply.find("result");
  return result == reply.end() ? json() : *result;
}

bool parse_state_frame(const std::string& text, StateFrame& frame) {
  const json f = json::parse(text, nullptr, false);
  if (f.is_discarded() || !f.is_object()) throw LinkError("malformed state frame");
  if (f.contains("id")) {  // the subscription's answer
    if (f.contains("error")) throw LinkError("subscription refused: " + f["error"].dump());
    return false;
  }
  StateFrame next;
  next.q = joint_vector(f.value("R1_actual_q", json()), "R1_actual_q");
  next.qd = joint_vector(f.value("R1_actual_qd", json()), "R1_actual_qd");
  next.robot_mode = mode_field(f, "R1_robot_mode");
  next.safety_mode = mode_field(f, "R1_safety_mode");
  frame = std::move(next);
  return true;
}

}  // namespace weldtwin::aubo
