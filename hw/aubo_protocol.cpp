#include "hw/aubo_protocol.hpp"

namespace weldtwin::aubo {

using nlohmann::json;

const std::vector<std::string>& state_segments() {
  static const std::vector<std::string> s = {"R1_actual_q", "R1_actual_qd", "R1_robot_mode",
                                             "R1_safety_mode"};
  return s;
}

std::string subscription(int channel, double frequency_hz) {
  const json recipe = {{"chanel", channel},  // the vendor's spelling
                       {"frequency", frequency_hz},
                       {"segments", state_segments()},
                       {"to_server", false},
                       {"trigger", 0}};
  const std::vector<std::uint8_t> bytes = json::to_msgpack(json::array({kSubscribeIndex, recipe}));
  return std::string(bytes.begin(), bytes.end());
}

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

void expect_success(const json& result, const std::string& method) {
  if (!result.is_number_integer()) throw LinkError(method + " answered " + result.dump() + ", not a code");
  if (result.get<long long>() != 0)
    throw Refused(method + " refused: error code " + std::to_string(result.get<long long>()));
}

bool parse_state_frame(const std::string& payload, StateFrame& frame) {
  const json f = json::from_msgpack(payload, true, false);
  if (f.is_discarded() || !f.is_array() || f.empty() || !f[0].is_number_integer())
    throw LinkError("malformed state frame (not a MessagePack array led by its channel)");
  if (f[0] == kSubscribeIndex) {  // the subscription's answer
    if (f.size() < 2 || !f[1].is_number_integer() || f[1].get<long long>() < 0)
      throw LinkError("subscription refused: " +
                      f.dump(-1, ' ', false, json::error_handler_t::replace).substr(0, 120));
    return false;
  }
  if (f.size() != 1 + state_segments().size())
    throw LinkError("malformed state frame: " + std::to_string(f.size() - 1) + " values for " +
                    std::to_string(state_segments().size()) + " segments");
  StateFrame next;
  next.q = joint_vector(f[1], "R1_actual_q");
  next.qd = joint_vector(f[2], "R1_actual_qd");
  if (!f[3].is_string()) throw LinkError("malformed state frame: R1_robot_mode is not a name");
  if (!f[4].is_string()) throw LinkError("malformed state frame: R1_safety_mode is not a name");
  next.robot_mode = f[3].get<std::string>();
  next.safety_mode = f[4].get<std::string>();
  frame = std::move(next);
  return true;
}

}  // namespace weldtwin::aubo
