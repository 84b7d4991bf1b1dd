// The messages of the Aubo ARCS controller as the driver reads and writes them (hw/aubo_driver.cpp):
// JSON-RPC 2.0 on the command service (bare JSON objects), RTDE on the state service (MessagePack payloads
// in SOF frames, hw/json_link.hpp). docs/hardware.md says which of these forms come from the vendor's own
// examples and which are inferred. Each parser takes one message (as the link cuts them) and either returns
// what it holds or throws: LinkError for a malformed message, Refused for a request the controller refused.
// Nothing else leaves them.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "hw/json_link.hpp"

namespace weldtwin::aubo {

/// The controller answered a request with an error, or with a non-zero result code.
struct Refused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One RTDE frame, as far as we read it.
struct StateFrame {
  JointVector q = JointVector::Zero(), qd = JointVector::Zero();
  std::string robot_mode, safety_mode;
};

/// The RTDE index of a subscription message (the vendor's documentation: the first element, fixed at 100).
constexpr int kSubscribeIndex = 100;
/// The RTDE segments we subscribe, in the order a state frame carries their values.
const std::vector<std::string>& state_segments();
/// The subscription to state_segments() at `frequency_hz` on `channel`, MessagePack-encoded:
/// [100, {"chanel": channel, "frequency": f, "segments": [...], "to_server": false, "trigger": 0}].
std::string subscription(int channel, double frequency_hz);

/// Six numbers (joint positions or velocities) from a JSON array; LinkError naming `what` otherwise.
JointVector joint_vector(const nlohmann::json& a, const std::string& what);

/// The result of the reply to request `id` (of `method`, for the messages); nullopt for a message that
/// answers another request or none (a late answer, a notification). Throws Refused for an error answer,
/// LinkError for text that is not a JSON object.
std::optional<nlohmann::json> parse_reply(const std::string& text, int id, const std::string& method);

/// A command's result read as the controller's return code: 0 is success; any other integer throws Refused
/// naming `method` and the code. A result that is not an integer is a LinkError.
void expect_success(const nlohmann::json& result, const std::string& method);

/// Reads an RTDE payload (MessagePack) into `frame`: true for a state frame ([channel, q, qd, robot mode,
/// safety mode]), false for the subscription's answer ([100, channel], frame untouched). Throws LinkError for
/// a malformed payload (not MessagePack, a value missing or of the wrong type) or a refused subscription (a
/// negative channel).
bool parse_state_frame(const std::string& payload, StateFrame& frame);

}  // namespace weldtwin::aubo
