// A fake RPLIDAR A2 on the master side of a pseudo-terminal, run by the tests: it answers GET_HEALTH, takes
// the motor PWM and STOP, and streams SCAN nodes (400 a turn: node i at i * 0.9 deg, 1000 + i mm, quality 40)
// or EXPRESS_SCAN capsules (distances 2000 + i mm), as fast as the pty takes them.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "hw/rplidar.hpp"

namespace weldtwin::test {

class FakeA2 {
 public:
  enum class Health { kGood, kError };
  FakeA2(Health health = Health::kGood, int vanish_after_bytes = -1)
      : health_(health), vanish_after_(vanish_after_bytes) {
    master_ = posix_openpt(O_RDWR | O_NOCTTY);
    EXPECT_GE(master_, 0);
    grantpt(master_);
    unlockpt(master_);
    port_ = ptsname(master_);
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeA2() {
    quit_ = true;
    thread_.join();
    if (master_ >= 0) close(master_);
  }
  const std::string& port() const { return port_; }
  int last_pwm() const { return pwm_; }
  int stops() const { return stops_; }

  // Node i of every turn: angle i * 0.9 deg, distance 1000 + i mm, quality 40.
  static constexpr int kPerTurn = 400;

 private:
  void send(const std::vector<uint8_t>& b) {
    if (master_ < 0) return;
    size_t off = 0;
    while (off < b.size() && !quit_) {
      const ssize_t n = write(master_, b.data() + off, b.size() - off);
      if (n > 0)
        off += static_cast<size_t>(n);
      else
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    sent_ += static_cast<int>(b.size());
    if (vanish_after_ >= 0 && sent_ > vanish_after_) {  // unplugged
      close(master_);
      master_ = -1;
    }
  }
  void serve() {
    std::vector<uint8_t> in;
    int node = 0;
    double capsule_angle = 0;
    while (!quit_ && master_ >= 0) {
      pollfd p{master_, POLLIN, 0};
      if (poll(&p, 1, streaming_ ? 0 : 5) > 0 && (p.revents & POLLIN)) {
        uint8_t buf[256];
        const ssize_t n = read(master_, buf, sizeof buf);
        if (n > 0) in.insert(in.end(), buf, buf + n);
      }
      while (in.size() >= 2) {
        if (in[0] != 0xA5) {
          in.erase(in.begin());
          continue;
        }
        const uint8_t cmd = in[1];
        size_t len = 2;
        if (cmd & 0x80 || cmd == rplidar::kSetMotorPwm) {  // with a payload
          if (in.size() < 3 || in.size() < 4u + in[2]) break;
          len = 4u + in[2];
        }
        if (cmd == rplidar::kGetHealth) {
          send(rplidar::descriptor(3, 0, rplidar::kTypeHealth));
          send({static_cast<uint8_t>(health_ == Health::kGood ? 0 : 2), 0x12, 0x00});
        } else if (cmd == rplidar::kSetMotorPwm) {
          pwm_ = in[3] | (in[4] << 8);
        } else if (cmd == rplidar::kStop) {
          streaming_ = 0;
          ++stops_;
        } else if (cmd == rplidar::kScan) {
          send(rplidar::descriptor(5, 1, rplidar::kTypeScan));
          streaming_ = 1;
          node = 123;  // mid-turn: the driver must drop the partial turn
        } else if (cmd == rplidar::kExpressScan) {
          send(rplidar::descriptor(84, 1, rplidar::kTypeExpress));
          streaming_ = 2;
          capsule_angle = 100.0;
        }
        in.erase(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(len));
      }
      if (streaming_ == 1) {
        std::vector<uint8_t> chunk;
        for (int k = 0; k < 40; ++k, ++node) {
          RplidarNode n;
          const int i = node % kPerTurn;
          n.angle_deg = i * 0.9;
          n.distance_mm = 1000 + i;
          n.quality = 40;
          n.start = i == 0;
          const auto b = rplidar::encode_node(n);
          chunk.insert(chunk.end(), b.begin(), b.end());
        }
        send(chunk);
      } else if (streaming_ == 2) {
        double d[32], q[32];
        for (int i = 0; i < 32; ++i) d[i] = 2000 + i, q[i] = 0.0;
        send(rplidar::encode_capsule(capsule_angle, false, d, q));
        capsule_angle = std::fmod(capsule_angle + 14.4, 360.0);
      }
      if (streaming_) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }

  Health health_;
  int vanish_after_, sent_ = 0;
  int master_ = -1;
  std::string port_;
  std::thread thread_;
  std::atomic<bool> quit_{false};
  std::atomic<int> pwm_{-1}, stops_{0}, streaming_{0};
};

}  // namespace weldtwin::test
