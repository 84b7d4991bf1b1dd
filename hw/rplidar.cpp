#include "hw/rplidar.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/error.hpp"

namespace weldtwin {
namespace rplidar {
namespace {

uint16_t u16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (p[1] << 8));
}

double wrap360(double deg) {
  deg = std::fmod(deg, 360.0);
  return deg < 0 ? deg + 360.0 : deg;
}

}  // namespace

std::vector<uint8_t> request(uint8_t cmd, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> out{0xA5, cmd};
  if (payload.empty()) return out;
  out.push_back(static_cast<uint8_t>(payload.size()));
  out.insert(out.end(), payload.begin(), payload.end());
  uint8_t sum = 0;
  for (uint8_t b : out) sum ^= b;
  out.push_back(sum);
  return out;
}

std::vector<uint8_t> descriptor(uint32_t length, uint8_t mode, uint8_t type) {
  const uint32_t v = (length & 0x3FFFFFFF) | (static_cast<uint32_t>(mode) << 30);
  return {0xA5,
          0x5A,
          static_cast<uint8_t>(v),
          static_cast<uint8_t>(v >> 8),
          static_cast<uint8_t>(v >> 16),
          static_cast<uint8_t>(v >> 24),
          type};
}

std::vector<uint8_t> encode_node(const RplidarNode& n) {
  const uint16_t angle_q6 = static_cast<uint16_t>(std::lround(wrap360(n.angle_deg) * 64.0) % (360 * 64));
  const uint16_t dist_q2 = static_cast<uint16_t>(std::lround(n.distance_mm * 4.0));
  const uint8_t s = n.start ? 1 : 0;
  return {static_cast<uint8_t>((std::min<uint8_t>(n.quality, 63) << 2) | ((s ^ 1) << 1) | s),
          static_cast<uint8_t>(((angle_q6 & 0x7F) << 1) | 1), static_cast<uint8_t>(angle_q6 >> 7),
          static_cast<uint8_t>(dist_q2), static_cast<uint8_t>(dist_q2 >> 8)};
}

std::vector<uint8_t> encode_capsule(double start_angle_deg, bool new_turn, const double (&distance_mm)[32],
                                    const double (&compensation_deg)[32]) {
  std::vector<uint8_t> c(84, 0);
  const uint16_t start = static_cast<uint16_t>(std::lround(wrap360(start_angle_deg) * 64.0) % (360 * 64));
  c[2] = static_cast<uint8_t>(start);
  c[3] = static_cast<uint8_t>((start >> 8) | (new_turn ? 0x80 : 0));
  for (int k = 0; k < 16; ++k) {
    uint8_t* cab = &c[static_cast<size_t>(4 + 5 * k)];
    int comp[2];
    for (int h = 0; h < 2; ++h) {
      comp[h] = static_cast<int>(std::lround(compensation_deg[2 * k + h] * 8.0)) & 0x3F;  // 6-bit, q3
      const uint16_t d =
          static_cast<uint16_t>((std::lround(distance_mm[2 * k + h]) & 0x3FFF) << 2 | (comp[h] >> 4));
      cab[2 * h] = static_cast<uint8_t>(d);
      cab[2 * h + 1] = static_cast<uint8_t>(d >> 8);
    }
    cab[4] = static_cast<uint8_t>((comp[0] & 0xF) | ((comp[1] & 0xF) << 4));
  }
  uint8_t sum = 0;
  for (size_t i = 2; i < c.size(); ++i) sum ^= c[i];
  c[0] = static_cast<uint8_t>(0xA0 | (sum & 0xF));
  c[1] = static_cast<uint8_t>(0x50 | (sum >> 4));
  return c;
}

void StreamBuffer::feed(const uint8_t* data, size_t n) {
  if (pos > 4096) {
    bytes.erase(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(pos));
    pos = 0;
  }
  bytes.insert(bytes.end(), data, data + n);
}

bool decode_node(const uint8_t* b, RplidarNode& node) {
  const uint8_t s = b[0] & 1, ns = (b[0] >> 1) & 1;
  const uint16_t angle_q6 = static_cast<uint16_t>((b[1] >> 1) | (b[2] << 7));
  if (s == ns || (b[1] & 1) == 0 || angle_q6 >= 360 * 64) return false;
  node.start = s == 1;
  node.quality = static_cast<uint8_t>(b[0] >> 2);
  node.angle_deg = angle_q6 / 64.0;
  node.distance_mm = u16(b + 3) / 4.0;
  return true;
}

namespace {

// Whether `b` can follow `a` in one stream: the angle moves on by a little, or a new turn starts.
constexpr double kMaxStepBack_deg = 10.0, kMaxStepOn_deg = 10.0;

bool follows(const RplidarNode& a, const RplidarNode& b) {
  if (b.start) return true;
  // A real A2's angles do not only increase: next to a node without a return they step back or on by up to
  // 8.3 deg (captures of a device: a window of -0.5..5 deg lost 3 % of their nodes).
  const double step = b.angle_deg - a.angle_deg;
  return (step > -kMaxStepBack_deg && step < kMaxStepOn_deg) || step < -350.0;
}

}  // namespace

bool NodeDecoder::next(RplidarNode& node) {
  // The checks pass for one window in six of random bytes, so a stream is taken as found only where three
  // nodes in a row pass them and follow each other; after that, a node that fails either test loses the lock.
  while (in_.available() >= 5) {
    const uint8_t* b = in_.here();
    if (locked_) {
      RplidarNode n;
      if (decode_node(b, n) && follows(last_, n)) {
        node = last_ = n;
        in_.pos += 5;
        return true;
      }
      locked_ = false;
    }
    if (in_.available() < 15) return false;  // wait for three nodes' worth
    RplidarNode n0, n1, n2;
    if (decode_node(b, n0) && decode_node(b + 5, n1) && decode_node(b + 10, n2) && follows(n0, n1) &&
        follows(n1, n2)) {
      locked_ = true;
      node = last_ = n0;
      in_.pos += 5;
      return true;
    }
    ++in_.pos;
    ++skipped_;
  }
  return false;
}

bool CapsuleDecoder::parse(Capsule& c) {
  while (in_.available() >= 84) {
    const uint8_t* b = in_.here();
    if ((b[0] >> 4) != 0xA || (b[1] >> 4) != 0x5) {
      ++in_.pos;
      ++skipped_;
      continue;
    }
    uint8_t sum = 0;
    for (int i = 2; i < 84; ++i) sum ^= b[i];
    if (sum != static_cast<uint8_t>((b[0] & 0xF) | ((b[1] & 0xF) << 4))) {
      // A corrupted capsule (or a false sync): its samples are lost, and the one before it cannot be
      // placed (its angles need this one's start); look for the next sync.
      ++bad_;
      ++in_.pos;
      ++skipped_;
      have_previous_ = false;
      continue;
    }
    c.start_deg = (u16(b + 2) & 0x7FFF) / 64.0;
    c.new_turn = (b[3] & 0x80) != 0;
    for (int k = 0; k < 16; ++k) {
      const uint8_t* cab = b + 4 + 5 * k;
      for (int h = 0; h < 2; ++h) {
        const uint16_t d = u16(cab + 2 * h);
        int comp = ((h == 0 ? cab[4] : cab[4] >> 4) & 0xF) | ((d & 0x3) << 4);
        if (comp & 0x20) comp -= 64;  // 6-bit two's complement
        c.distance_mm[2 * k + h] = d >> 2;
        c.compensation_deg[2 * k + h] = comp / 8.0;
      }
    }
    in_.pos += 84;
    return true;
  }
  return false;
}

bool CapsuleDecoder::next(RplidarNode& node) {
  while (ready_pos_ >= ready_.size()) {
    ready_.clear();
    ready_pos_ = 0;
    Capsule c;
    if (!parse(c)) return false;
    if (have_previous_) {
      // The previous capsule's 32 samples lie evenly between its start angle and this one's.
      const double span = wrap360(c.start_deg - previous_.start_deg);
      for (int k = 0; k < 32; ++k) {
        RplidarNode n;
        n.angle_deg = wrap360(previous_.start_deg + span * k / 32.0 - previous_.compensation_deg[k]);
        n.distance_mm = previous_.distance_mm[k];
        n.quality = n.distance_mm > 0 ? 47 : 0;
        ready_.push_back(n);
      }
    }
    previous_ = c;
    have_previous_ = true;
  }
  node = ready_[ready_pos_++];
  return true;
}

}  // namespace rplidar

// --- the device ---

RplidarDevice::RplidarDevice(const std::string& port, double timeout_s) : port_(port), timeout_s_(timeout_s) {
  fd_ = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd_ < 0)
    throw input_error(port, std::string("cannot open the RPLIDAR's port: ") + std::strerror(errno));
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) {
    ::close(fd_);
    throw input_error(port, "not a serial port");
  }
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  tio.c_cflag |= CLOCAL | CREAD;
  tcsetattr(fd_, TCSANOW, &tio);
  tcflush(fd_, TCIOFLUSH);
}

RplidarDevice::~RplidarDevice() {
  if (fd_ < 0) return;
  try {
    stop();
    set_motor_pwm(0);
  } catch (...) {  // the device may be gone; nothing more to do
  }
  ::close(fd_);
}

void RplidarDevice::write_all(const std::vector<uint8_t>& bytes) {
  size_t off = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (off < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + off, bytes.size() - off);
    if (n > 0) {
      off += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN)
      throw input_error(port_, std::string("write failed: ") + std::strerror(errno));
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > timeout_s_)
      throw input_error(port_, "the port does not take our request");
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, 10);
  }
}

size_t RplidarDevice::read_some(uint8_t* buf, size_t n) {
  pollfd p{fd_, POLLIN, 0};
  const int r = poll(&p, 1, static_cast<int>(timeout_s_ * 1000));
  if (r == 0)
    throw input_error(port_, "the RPLIDAR stopped answering (no data for " +
                                 std::to_string(timeout_s_).substr(0, 4) + " s)");
  const ssize_t got = ::read(fd_, buf, n);
  if (got > 0) return static_cast<size_t>(got);
  if (got < 0 && errno == EAGAIN) return 0;
  throw input_error(port_, "the RPLIDAR is gone (unplugged?)");
}

std::vector<uint8_t> RplidarDevice::read_exact(size_t n) {
  std::vector<uint8_t> out(n);
  for (size_t off = 0; off < n;) off += read_some(out.data() + off, n - off);
  return out;
}

void RplidarDevice::expect_descriptor(uint8_t type) {
  // Anything before A5 5A is garbage (the tail of an earlier stream): skip it.
  uint8_t prev = 0, b = 0;
  for (size_t skipped = 0;; ++skipped) {
    if (skipped > 4096)
      throw input_error(port_, "no response descriptor in 4 kB (wrong device or baud rate?)");
    while (read_some(&b, 1) == 0) {
    }
    if (prev == 0xA5 && b == 0x5A) break;
    prev = b;
  }
  const std::vector<uint8_t> rest = read_exact(5);
  if (rest[4] != type)
    throw input_error(port_, "unexpected response type " + std::to_string(rest[4]) + " (wanted " +
                                 std::to_string(type) + ")");
}

void RplidarDevice::check_health() {
  tcflush(fd_, TCIFLUSH);
  write_all(rplidar::request(rplidar::kGetHealth));
  expect_descriptor(rplidar::kTypeHealth);
  const std::vector<uint8_t> h = read_exact(3);
  if (h[0] == 2)
    throw input_error(port_, "the RPLIDAR reports an error (code " + std::to_string(h[1] | (h[2] << 8)) +
                                 "); power-cycle it");
}

void RplidarDevice::set_motor_pwm(int pwm) {
  // The A2 on its USB adapter runs its motor while DTR is low; with the accessory board, by PWM. Both.
  int dtr = TIOCM_DTR;
  ioctl(fd_, pwm > 0 ? TIOCMBIC : TIOCMBIS, &dtr);  // not every port has DTR (a pty has not): ignored
  const uint16_t v = static_cast<uint16_t>(std::clamp(pwm, 0, 1023));
  write_all(rplidar::request(rplidar::kSetMotorPwm, {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8)}));
}

void RplidarDevice::stop() {
  write_all(rplidar::request(rplidar::kStop));
}

void RplidarDevice::read_turns(bool express, int turns, ScanLog& log, double t0_s,
                               const std::atomic<bool>* until) {
  tcflush(fd_, TCIFLUSH);
  if (express)
    write_all(rplidar::request(rplidar::kExpressScan, {0, 0, 0, 0, 0}));
  else
    write_all(rplidar::request(rplidar::kScan));
  expect_descriptor(express ? rplidar::kTypeExpress : rplidar::kTypeScan);
  rplidar::NodeDecoder nodes;
  rplidar::CapsuleDecoder capsules;
  std::vector<RplidarNode> turn;
  double turn_start = -1.0, last_angle = -1.0;
  int done = 0;
  auto now = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count() - t0_s;
  };
  auto close_turn = [&](double t_end) {
    if (turn_start >= 0 && !turn.empty()) {
      LidarTurn lt;
      lt.t_start_s = turn_start;
      lt.first = static_cast<uint32_t>(log.samples.size());
      lt.count = static_cast<uint32_t>(turn.size());
      const double dt = (t_end - turn_start) / static_cast<double>(turn.size());
      for (size_t i = 0; i < turn.size(); ++i) {
        LidarSample s;
        s.t_s = turn_start + dt * static_cast<double>(i);
        double a = (360.0 - turn[i].angle_deg) * kPi / 180.0;  // clockwise degrees -> counter-clockwise
        a = std::fmod(a, 2 * kPi);
        s.angle_rad = static_cast<float>(a);
        s.range_m = static_cast<float>(turn[i].distance_mm / 1000.0);
        s.quality = s.range_m > 0 ? static_cast<uint8_t>(std::max(1, std::min(255, turn[i].quality * 4))) : 0;
        if (s.range_m <= 0) s.range_m = 0;
        log.samples.push_back(s);
      }
      log.turns.push_back(lt);
      ++done;
    }
    turn.clear();
    turn_start = t_end;
  };
  uint8_t buf[4096];
  while (done < turns && !(until && until->load())) {
    const size_t n = read_some(buf, sizeof buf);
    const double t = now();
    if (express)
      capsules.feed(buf, n);
    else
      nodes.feed(buf, n);
    RplidarNode node;
    while (express ? capsules.next(node) : nodes.next(node)) {
      // A new turn: the start flag (SCAN), or the angle wrapping round (express streams flag only the first).
      const bool start = express ? (last_angle >= 0 && node.angle_deg < last_angle - 180.0) : node.start;
      last_angle = node.angle_deg;
      if (start) close_turn(t);
      if (turn_start >= 0) turn.push_back(node);
      if (done >= turns) break;
    }
  }
  skipped_ += express ? capsules.skipped_bytes() : nodes.skipped_bytes();
  stop();
}

}  // namespace weldtwin
