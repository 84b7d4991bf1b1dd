// The RPLIDAR A2 protocol: SCAN nodes and EXPRESS_SCAN capsules decoded exactly (angles, distances, quality),
// garbage and corrupted bytes resynchronised without losing a turn, and the device driven over a
// pseudo-terminal by a fake A2 that the test runs: health, motor, both scan modes, stop; an unplugged port, a
// device that vanishes mid-scan and a device reporting an error each give a clear error.
#include "hw/rplidar.hpp"
#include "tests/real_data.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <mutex>
#include <random>
#include <thread>

#include "core/error.hpp"
#include "tests/support/fake_a2.hpp"

namespace weldtwin {
namespace {

std::vector<RplidarNode> decode_nodes(const std::vector<uint8_t>& bytes, rplidar::NodeDecoder& d) {
  d.feed(bytes.data(), bytes.size());
  std::vector<RplidarNode> out;
  RplidarNode n;
  while (d.next(n)) out.push_back(n);
  return out;
}

TEST(Rplidar, ScanNodesDecodeExactly) {
  std::mt19937 rng(1);
  std::vector<RplidarNode> sent;
  std::vector<uint8_t> bytes;
  for (int i = 0; i < 2000; ++i) {
    RplidarNode n;
    // Five turns of 400 nodes, a little uneven as the real motor is; q6 angles, q2 distances.
    n.angle_deg =
        std::round(((i % 400) * 0.9 + std::uniform_real_distribution<double>(0, 0.3)(rng)) * 64) / 64;
    n.distance_mm = std::floor(std::uniform_real_distribution<double>(0, 12000)(rng) * 4) / 4;  // q2
    n.quality = static_cast<uint8_t>(rng() % 64);
    n.start = i % 400 == 0;
    sent.push_back(n);
    const auto b = rplidar::encode_node(n);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  rplidar::NodeDecoder d;
  const auto got = decode_nodes(bytes, d);
  ASSERT_EQ(got.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].angle_deg, sent[i].angle_deg);
    EXPECT_EQ(got[i].distance_mm, sent[i].distance_mm);
    EXPECT_EQ(got[i].quality, sent[i].quality);
    EXPECT_EQ(got[i].start, sent[i].start);
  }
  EXPECT_EQ(d.skipped_bytes(), 0u);
}

// Bytes of a real A2-class unit's SCAN replies with the values another driver's tests assert for them (the
// MIT licensed yura/rplidar, spec/rplidar/scan_data_response_spec.rb and driver_spec.rb).
TEST(Rplidar, RealDeviceNodesDecodeToTheValuesAnotherDriverAsserts) {
  struct Fixture {
    uint8_t bytes[5];
    double angle_deg, distance_mm;
    int quality;
  };
  const Fixture fixtures[] = {{{62, 155, 2, 112, 4}, 5.203125, 284.0, 15},
                              {{62, 63, 3, 117, 4}, 6.484375, 285.25, 15}};
  for (const Fixture& f : fixtures) {
    RplidarNode n;
    ASSERT_TRUE(rplidar::decode_node(f.bytes, n));
    EXPECT_EQ(n.angle_deg, f.angle_deg);
    EXPECT_EQ(n.distance_mm, f.distance_mm);
    EXPECT_EQ(n.quality, f.quality);
    EXPECT_FALSE(n.start);
  }
  // The protocol's requests as that driver writes them: SCAN, and SET_MOTOR_PWM 660 with its checksum.
  EXPECT_EQ(rplidar::request(rplidar::kScan), (std::vector<uint8_t>{0xA5, 0x20}));
  EXPECT_EQ(rplidar::request(rplidar::kSetMotorPwm, {0x94, 0x02}),
            (std::vector<uint8_t>{0xA5, 0xF0, 0x02, 0x94, 0x02, 0xC1}));
}

// Raw SCAN node streams captured from a device (they start mid-stream), where the real-data folder is present
// (WELDTWIN_REAL_DATA, or ../shared/real beside the repository): the decoder finds the stream within its
// first nodes, then reads it to the end without losing a byte, every angle within a turn.
TEST(Rplidar, RealCapturedStreamsAreReadWhole) {
  const std::string dir = test::real_data("rplidar/scan_node_stream");
  if (!std::ifstream(dir + "/frame_0002.bin")) GTEST_SKIP() << "skipped: " << dir << " not found";
  for (const char* name : {"frame_0002.bin", "frame_0003.bin", "frame_0004.bin"}) {
    SCOPED_TRACE(name);
    std::ifstream in(dir + "/" + name, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 5000u);
    rplidar::NodeDecoder d;
    const auto nodes = decode_nodes(bytes, d);
    // Each capture begins with a few nodes cut off (16 windows that fail the checks): the lock comes after
    // them, and nothing is skipped after it (a window of -0.5..5 deg between nodes had skipped 272-369
    // bytes).
    EXPECT_LT(d.skipped_bytes(), 60u);
    EXPECT_GE(5 * nodes.size() + d.skipped_bytes() + 5, bytes.size()) << "and then nothing is lost";
    int starts = 0;
    for (const RplidarNode& n : nodes) {
      EXPECT_GE(n.angle_deg, 0.0);
      EXPECT_LT(n.angle_deg, 360.0);
      starts += n.start;
    }
    EXPECT_GE(starts, 1) << "a turn starts in every capture";
  }
}

TEST(Rplidar, ScanStreamResynchronisesAfterGarbage) {
  std::vector<RplidarNode> sent;
  std::vector<uint8_t> bytes = {0x13, 0x37, 0x00, 0xFF, 0x42, 0x99, 0x7};  // the tail of something else
  for (int i = 0; i < 400; ++i) {
    RplidarNode n;
    n.angle_deg = std::round(i * 0.9 * 64) / 64;  // q6, as the device has it
    n.distance_mm = 500 + i;
    n.quality = 40;
    n.start = i == 0;
    sent.push_back(n);
    const auto b = rplidar::encode_node(n);
    bytes.insert(bytes.end(), b.begin(), b.end());
  }
  bytes[7 + 5 * 200 + 1] ^= 0x01;  // node 200's check bit cleared: a byte corrupted on the wire
  rplidar::NodeDecoder d;
  const auto got = decode_nodes(bytes, d);
  // Every node but the corrupted one comes through, in order; at most a couple of spurious ones in the
  // garbage.
  size_t at = 0, matched = 0;
  for (const RplidarNode& want : sent)
    for (size_t j = at; j < got.size(); ++j)
      if (got[j].angle_deg == want.angle_deg && got[j].distance_mm == want.distance_mm) {
        ++matched;
        at = j + 1;
        break;
      }
  EXPECT_GE(matched, sent.size() - 1);
  EXPECT_LE(got.size(), sent.size() + 2);
  EXPECT_GT(d.skipped_bytes(), 0u);
}

// Capsule samples: distances and compensations for `count` capsules whose start angles step by `span`.
struct Capsules {
  std::vector<uint8_t> bytes;
  std::vector<double> start;
  std::vector<std::array<double, 32>> dist, comp;
};

Capsules make_capsules(int count, double span, std::mt19937& rng) {
  Capsules c;
  for (int k = 0; k < count; ++k) {
    double d[32], q[32];
    std::array<double, 32> da{}, qa{};
    for (int i = 0; i < 32; ++i) {
      d[i] = da[static_cast<size_t>(i)] = static_cast<double>(rng() % 16000);
      q[i] = qa[static_cast<size_t>(i)] = (static_cast<int>(rng() % 64) - 32) / 8.0;  // -4 .. 3.875 deg, q3
    }
    const double start = std::fmod(10.0 + k * span, 360.0);
    const double start_q6 = std::round(start * 64) / 64;
    const auto b = rplidar::encode_capsule(start_q6, k == 0, d, q);
    c.bytes.insert(c.bytes.end(), b.begin(), b.end());
    c.start.push_back(start_q6);
    c.dist.push_back(da);
    c.comp.push_back(qa);
  }
  return c;
}

double expected_angle(const Capsules& c, size_t k, int i) {
  double span = c.start[k + 1] - c.start[k];
  if (span < 0) span += 360;
  double a = std::fmod(c.start[k] + span * i / 32.0 - c.comp[k][static_cast<size_t>(i)], 360.0);
  return a < 0 ? a + 360 : a;
}

TEST(Rplidar, ExpressCapsulesDecodeExactly) {
  std::mt19937 rng(2);
  const Capsules c = make_capsules(30, 14.4, rng);  // 32 samples per 14.4 deg: 800 a turn
  rplidar::CapsuleDecoder d;
  d.feed(c.bytes.data(), c.bytes.size());
  std::vector<RplidarNode> got;
  RplidarNode n;
  while (d.next(n)) got.push_back(n);
  ASSERT_EQ(got.size(), 29u * 32u) << "the last capsule waits for the next one's start angle";
  for (size_t k = 0; k + 1 < c.start.size(); ++k)
    for (int i = 0; i < 32; ++i) {
      const RplidarNode& g = got[k * 32 + static_cast<size_t>(i)];
      EXPECT_EQ(g.distance_mm, c.dist[k][static_cast<size_t>(i)]);
      EXPECT_NEAR(g.angle_deg, expected_angle(c, k, i), 1e-9);
    }
  EXPECT_EQ(d.bad_capsules(), 0u);
}

TEST(Rplidar, ACorruptedCapsuleCostsItsSamplesNotATurn) {
  std::mt19937 rng(3);
  Capsules c = make_capsules(60, 14.4, rng);
  c.bytes[84 * 20 + 40] ^= 0x10;                           // a bit flipped inside capsule 20
  std::vector<uint8_t> stream = {0x55, 0xA0, 0x51, 0x02};  // garbage first, with a false sync in it
  stream.insert(stream.end(), c.bytes.begin(), c.bytes.end());
  rplidar::CapsuleDecoder d;
  std::vector<RplidarNode> got;
  for (size_t off = 0; off < stream.size(); off += 37) {  // as the bytes arrive, in pieces
    d.feed(stream.data() + off, std::min<size_t>(37, stream.size() - off));
    RplidarNode n;
    while (d.next(n)) got.push_back(n);
  }
  EXPECT_GE(d.bad_capsules(), 1u);  // the corrupted one (and the false sync in the garbage)
  EXPECT_GE(got.size(), 59u * 32u - 64u) << "at most the corrupted capsule and the one before it";
  // Every sample that came through is right: each matches its capsule's.
  size_t checked = 0;
  for (size_t k = 0; k + 1 < c.start.size(); ++k) {
    if (k == 19 || k == 20) continue;
    for (int i = 0; i < 32; ++i) {
      const double a = expected_angle(c, k, i), dist = c.dist[k][static_cast<size_t>(i)];
      const bool found = std::any_of(got.begin(), got.end(), [&](const RplidarNode& g) {
        return std::abs(g.angle_deg - a) < 1e-9 && g.distance_mm == dist;
      });
      EXPECT_TRUE(found) << "capsule " << k << " sample " << i;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 57u * 32u);
}

TEST(Rplidar, DrivesTheFakeDeviceThroughBothScanModes) {
  test::FakeA2 fake;
  ScanLog log;
  {
    RplidarDevice lidar(fake.port(), 2.0);
    lidar.check_health();
    lidar.set_motor_pwm(rplidar::kDefaultPwm);
    lidar.read_turns(false, 2, log, 0.0);
    ASSERT_EQ(log.turns.size(), 2u);
    for (const LidarTurn& t : log.turns) {
      ASSERT_EQ(t.count, static_cast<uint32_t>(test::FakeA2::kPerTurn)) << "whole turns only";
      for (uint32_t i = 0; i < t.count; i += 7) {
        const LidarSample& s = log.samples[t.first + i];
        EXPECT_FLOAT_EQ(s.range_m, static_cast<float>((1000 + i) / 1000.0));
        const double q6 = std::round(i * 0.9 * 64.0) / 64.0;  // as the device quantizes it
        const double ccw = std::fmod(360.0 - q6, 360.0) * kPi / 180.0;
        EXPECT_NEAR(s.angle_rad, ccw, 1e-6);
        EXPECT_EQ(s.quality, 160);
      }
      EXPECT_LT(log.samples[t.first].t_s, log.samples[t.first + t.count - 1].t_s);
    }
    const size_t scan_samples = log.samples.size();
    lidar.read_turns(true, 1, log, 0.0);  // express: 25 capsules a turn
    ASSERT_EQ(log.turns.size(), 3u);
    const LidarTurn& e = log.turns.back();
    EXPECT_NEAR(static_cast<double>(e.count), 800.0, 32.0);
    for (uint32_t i = 0; i < e.count; ++i) {
      const LidarSample& s = log.samples[scan_samples + i];
      EXPECT_GE(s.range_m, 1.999f);
      EXPECT_LE(s.range_m, 2.032f);
    }
    EXPECT_EQ(fake.last_pwm(), rplidar::kDefaultPwm);
  }
  // The driver stops scanning after each read and again, with the motor, when it goes.
  for (int wait = 0; wait < 200 && (fake.stops() < 3 || fake.last_pwm() != 0); ++wait)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_GE(fake.stops(), 3);
  EXPECT_EQ(fake.last_pwm(), 0);
}

TEST(Rplidar, UnpluggedVanishingAndFaultyDevicesGiveClearErrors) {
  try {
    RplidarDevice lidar("/dev/ttyUSB-not-there");
    ADD_FAILURE() << "opened a port that does not exist";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
  {
    test::FakeA2 fake(test::FakeA2::Health::kGood, 3000);  // gone after 3 kB of scan
    RplidarDevice lidar(fake.port(), 1.0);
    ScanLog log;
    try {
      lidar.read_turns(false, 5, log, 0.0);
      ADD_FAILURE() << "read turns from a device that went away";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_TRUE(what.find("gone") != std::string::npos ||
                  what.find("stopped answering") != std::string::npos)
          << what;
    }
  }
  {
    test::FakeA2 fake(test::FakeA2::Health::kError);
    RplidarDevice lidar(fake.port(), 1.0);
    try {
      lidar.check_health();
      ADD_FAILURE() << "a device in error passed the health check";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("reports an error (code 18)"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace weldtwin
