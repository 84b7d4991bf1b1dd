// The RPLIDAR A2 over its published serial protocol (115200 baud, 8N1): requests `A5 cmd [size payload
// checksum]`, response descriptors `A5 5A len|mode type`, and the two scan streams —
//   SCAN (0x20): 5-byte nodes (start flag and its inverse, quality, check bit, angle q6, distance q2), and
//   EXPRESS_SCAN (0x82): 84-byte capsules (sync nibbles, XOR checksum, start angle q6, 16 cabins of two
//   distances and two angle compensations; a capsule's angles need the next capsule's start angle).
// The decoders resynchronise after garbage: a bad node costs its 5 bytes, a bad capsule its 32 samples.
// Angles come out as the ScanLog has them: counter-clockwise radians (the device counts clockwise degrees).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "core/scan_log.hpp"

namespace weldtwin {

struct RplidarNode {
  double angle_deg = 0.0;    ///< as the device reports it: clockwise degrees, [0, 360)
  double distance_mm = 0.0;  ///< 0: no return
  uint8_t quality = 0;       ///< 0..63 in SCAN mode; express nodes report 0 or 47 (no quality in the stream)
  bool start = false;        ///< first node of a new turn
};

namespace rplidar {

constexpr uint8_t kStop = 0x25, kReset = 0x40, kScan = 0x20, kExpressScan = 0x82, kGetHealth = 0x52,
                  kSetMotorPwm = 0xF0;
constexpr uint8_t kTypeHealth = 0x06, kTypeScan = 0x81, kTypeExpress = 0x82;
constexpr int kDefaultPwm = 660;

/// A request: A5 cmd, and for a payload: size, payload, XOR checksum of everything before.
std::vector<uint8_t> request(uint8_t cmd, const std::vector<uint8_t>& payload = {});
/// A response descriptor: A5 5A, 30-bit length and 2-bit mode (1: a stream), data type.
std::vector<uint8_t> descriptor(uint32_t length, uint8_t mode, uint8_t type);

/// Encodes a SCAN node (the fake device of the tests speaks through these).
std::vector<uint8_t> encode_node(const RplidarNode& n);
/// Encodes an express capsule: its start angle, whether a turn starts in it, and 32 samples (distances [mm]
/// and compensation angles [deg], both within the protocol's range).
std::vector<uint8_t> encode_capsule(double start_angle_deg, bool new_turn, const double (&distance_mm)[32],
                                    const double (&compensation_deg)[32]);

/// The SCAN node in the 5 bytes at `b`, if they pass the protocol's checks (the start flag against its
/// inverse, the check bit, an angle within a turn); false otherwise.
bool decode_node(const uint8_t* b, RplidarNode& node);

/// Bytes as they arrive, consumed from the front (kept compact).
struct StreamBuffer {
  std::vector<uint8_t> bytes;
  size_t pos = 0;
  void feed(const uint8_t* data, size_t n);
  size_t available() const { return bytes.size() - pos; }
  const uint8_t* here() const { return bytes.data() + pos; }
};

/// SCAN-mode stream decoder.
class NodeDecoder {
 public:
  void feed(const uint8_t* data, size_t n) { in_.feed(data, n); }
  /// The next whole, valid node; false when more bytes are needed.
  bool next(RplidarNode& node);
  size_t skipped_bytes() const { return skipped_; }

 private:
  StreamBuffer in_;
  size_t skipped_ = 0;
  bool locked_ = false;
  RplidarNode last_;
};

/// EXPRESS_SCAN stream decoder.
class CapsuleDecoder {
 public:
  void feed(const uint8_t* data, size_t n) { in_.feed(data, n); }
  bool next(RplidarNode& node);
  size_t bad_capsules() const { return bad_; }
  size_t skipped_bytes() const { return skipped_; }

 private:
  struct Capsule {
    double start_deg = 0.0;
    bool new_turn = false;
    double distance_mm[32] = {}, compensation_deg[32] = {};
  };
  bool parse(Capsule& c);
  StreamBuffer in_;
  size_t skipped_ = 0, bad_ = 0;
  bool have_previous_ = false;
  Capsule previous_;
  std::vector<RplidarNode> ready_;
  size_t ready_pos_ = 0;
};

}  // namespace rplidar

/// The device on a serial port. Every exchange has a timeout; errors are InputErrors naming the port.
class RplidarDevice {
 public:
  /// Opens the port (115200 8N1, raw). Throws InputError when it cannot (unplugged, no permission).
  RplidarDevice(const std::string& port, double timeout_s = 1.0);
  ~RplidarDevice();  ///< stops the scan and the motor
  RplidarDevice(const RplidarDevice&) = delete;
  RplidarDevice& operator=(const RplidarDevice&) = delete;

  /// GET_HEALTH: throws unless the device reports good health (status 0).
  void check_health();
  /// SET_MOTOR_PWM (the A2's accessory board); 0 stops the motor.
  void set_motor_pwm(int pwm);
  /// Starts SCAN or EXPRESS_SCAN and reads `turns` whole turns (the partial turn before the first start
  /// flag is dropped), or until `*until` is set, timestamping each turn's samples evenly between its start
  /// and the next turn's on the host's steady clock, seconds from `t0`. Throws on silence longer than the
  /// timeout or a closed device.
  void read_turns(bool express, int turns, ScanLog& log, double t0_s,
                  const std::atomic<bool>* until = nullptr);
  /// STOP.
  void stop();
  size_t skipped_bytes() const { return skipped_; }

 private:
  void write_all(const std::vector<uint8_t>& bytes);
  size_t read_some(uint8_t* buf, size_t n);  ///< waits up to the timeout; throws on silence or hang-up
  std::vector<uint8_t> read_exact(size_t n);
  void expect_descriptor(uint8_t type);
  std::string port_;
  int fd_ = -1;
  double timeout_s_;
  size_t skipped_ = 0;
};

}  // namespace weldtwin
