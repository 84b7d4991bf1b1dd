// The RPLIDAR byte-stream decoders (SCAN nodes, EXPRESS_SCAN capsules), fed as a serial port delivers bytes:
// in chunks. The first byte picks the decoder (even: SCAN, odd: EXPRESS) and the chunk size (1..128 bytes).
// Garbage must only be skipped: every node that comes out has an angle in [0, 360) and a finite distance
// >= 0, and the decoder never reports more bytes skipped than it was fed.
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "hw/rplidar.hpp"

namespace {

template <class Decoder>
void run(Decoder& d, const uint8_t* data, size_t size, size_t chunk) {
  weldtwin::RplidarNode n;
  for (size_t at = 0; at < size; at += chunk) {
    d.feed(data + at, std::min(chunk, size - at));
    while (d.next(n))
      if (!(n.angle_deg >= 0.0 && n.angle_deg < 360.0) || !std::isfinite(n.distance_mm) ||
          n.distance_mm < 0.0)
        std::abort();
  }
  if (d.skipped_bytes() > size) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const size_t chunk = 1 + (data[0] >> 1) % 128;
  if (data[0] % 2 == 0) {
    weldtwin::rplidar::NodeDecoder d;
    run(d, data + 1, size - 1, chunk);
  } else {
    weldtwin::rplidar::CapsuleDecoder d;
    run(d, data + 1, size - 1, chunk);
  }
  return 0;
}
