// The messages of the Aubo ARCS controller as the driver reads them (hw/aubo_driver.cpp): JSON-RPC 2.0
// replies on the command service, RTDE state frames on the state service. Each parser takes one JSON object's
// text (as JsonFramer cuts them) and either returns what it holds or throws: LinkError for a malformed
// message, Refused for a request the controller refused. Nothing else leaves them.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/robot_model.hpp"
#include "hw/json_link.hpp"

namespace weldtwin::aubo {

/// The controller answered a request with an error.
struct Refused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// One RTDE frame, as far as we read it.
struct StateFrame {
  JointVector q = JointVector::Zero(), qd = JointVector::Zero();
  std::string robot_mode, safety_mode;
};

/// Six numbers (joint positions or velocities) from a JSON array; LinkError naming `what` otherwise.
JointVector joint_vector(const nlohmann::json& a, const std::string& what);

/// The result of the reply to request `id` (of `method`, for the messages); nullopt for a message that
/// answers another request or none (a late answer, a notification). Throws Refused for an error answer,
/// LinkError for text that is not a JSON object.
std::optional<nlohmann::json> parse_reply(const std::string& text, int id, const std::string& method);

/// Reads an RTDE message into `frame`: true for a state frame, false for the subscription's answer (frame
/// untouched). Throws LinkError for a malformed frame (a field missing or of the wrong type) or a refused
/// subscription.
bool parse_state_frame(const std::string& text, StateFrame& frame);

}  // namespace weldtwin::aubo
