// What the robot controller sends: a byte stream cut into messages as the driver's two connections cut them
// (hw/json_link): the command service's bare JSON objects (JsonFramer), each read as a JSON-RPC reply and a
// result code, or the state service's SOF frames (SofFramer), each payload read as an RTDE state frame
// (hw/aubo_protocol). The first byte picks the stream (its lowest bit) and the chunk size (the rest: 1..128).
// Bad messages must end in LinkError or Refused, nothing else; every object the framer cuts begins with '{'
// and ends with its closing bracket ('}', or a mismatched ']' that the parsers then refuse), every payload
// is at most 65535 bytes, and neither framer holds more than it was fed.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hw/aubo_protocol.hpp"
#include "hw/json_link.hpp"

namespace {

void read_reply(const std::string& object) {
  if (object.empty() || object.front() != '{' || (object.back() != '}' && object.back() != ']')) std::abort();
  try {
    if (const auto result = weldtwin::aubo::parse_reply(object, 1, "fuzz"))
      weldtwin::aubo::expect_success(*result, "fuzz");
  } catch (const weldtwin::LinkError&) {
  } catch (const weldtwin::aubo::Refused&) {
  }
}

void read_state(const std::string& payload) {
  if (payload.size() > weldtwin::SofFramer::kMaxPayloadBytes) std::abort();
  try {
    weldtwin::aubo::StateFrame frame;
    weldtwin::aubo::parse_state_frame(payload, frame);
  } catch (const weldtwin::LinkError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool state_stream = data[0] & 1;
  const size_t chunk = 1 + (data[0] >> 1);
  const char* bytes = reinterpret_cast<const char*>(data + 1);
  const size_t n = size - 1;
  weldtwin::JsonFramer objects;
  weldtwin::SofFramer frames;
  std::string message;
  for (size_t at = 0; at < n; at += chunk) {
    const size_t k = std::min(chunk, n - at);
    if (state_stream) {
      frames.feed(bytes + at, k);
      if (frames.pending() > n) std::abort();
      while (frames.next(message)) read_state(message);
    } else {
      objects.feed(bytes + at, k);
      if (objects.pending() > n) std::abort();
      while (objects.next(message)) read_reply(message);
    }
  }
  return 0;
}
