// What the robot controller sends: a byte stream cut into JSON objects (JsonFramer, as the command and state
// connections read them), each read as a JSON-RPC reply and as an RTDE state frame (hw/aubo_protocol). The
// first byte is the chunk size (1..256). Bad messages must end in LinkError or Refused, nothing else; every
// object the framer cuts begins with '{' and ends with its closing bracket ('}', or a mismatched ']' that the
// parsers then refuse), and it never holds more than it was fed.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hw/aubo_protocol.hpp"
#include "hw/json_link.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t chunk = 1 + data[0];
  const char* bytes = reinterpret_cast<const char*>(data + 1);
  const size_t n = size - 1;
  weldtwin::JsonFramer framer;
  std::string object;
  for (size_t at = 0; at < n; at += chunk) {
    framer.feed(bytes + at, std::min(chunk, n - at));
    if (framer.pending() > n) std::abort();
    while (framer.next(object)) {
      if (object.empty() || object.front() != '{' || (object.back() != '}' && object.back() != ']'))
        std::abort();
      try {
        weldtwin::aubo::parse_reply(object, 1, "fuzz");
      } catch (const weldtwin::LinkError&) {
      } catch (const weldtwin::aubo::Refused&) {
      }
      try {
        weldtwin::aubo::StateFrame frame;
        weldtwin::aubo::parse_state_frame(object, frame);
      } catch (const weldtwin::LinkError&) {
      }
    }
  }
  return 0;
}
