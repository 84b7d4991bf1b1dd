// The switch between simulated and recorded sweeps: a twin sweep recorded as a ScanLog, a ROS 1 bag and a ROS
// 2 bag, read back through the log: source, localizes to the same pose as the live sim source (within 1e-6
// m); the bags keep the samples' times against the joint states' (the alignment assembly interpolates by);
// bad bags and unknown sources are refused with the file named.
#include "hw/scan_source.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>

#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "hw/mcap.hpp"
#include "hw/ros_bags.hpp"
#include "perception/localizer.hpp"
#include "perception/mesh_io.hpp"
#include "perception/scan_assembly.hpp"
#include "tests/real_data.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / "weldtwin_scan_source_test";
  fs::create_directories(d);
  return d;
}

struct Recorded {
  test::Cell cell{"scenes/cells/default.yaml", 4};
  ScanLog live;
  Iso3 live_pose = Iso3::Identity();
  Mesh mesh;

  Recorded() {
    const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
    SimScanInputs sim;
    sim.world = cell.world.get();
    sim.robot = &cell.robot;
    sim.program = &program;
    sim.lidar.seed = 4;
    const auto source = make_scan_source("sim", cell.robot, sim);
    live = source->acquire();
    EXPECT_EQ(source->labels().size(), live.samples.size()) << "the twin knows what every sample saw";
    mesh = load_mesh(cell.part.mesh_path);
    live_pose = localize_log(live);
  }

  Iso3 localize_log(const ScanLog& log) const {
    LocalizeSetting setting;
    setting.threads = 1;
    const AssembledCloud a = assemble_scan(log, cell.robot);
    const PoseEstimate p =
        localize(a.points_base, mesh, setting, cell.part.seam_points(0.001), a.viewpoints_base);
    EXPECT_TRUE(p.found) << p.reason;
    return p.T_base_part;
  }
};

const Recorded& recorded() {
  static const Recorded r;
  return r;
}

TEST(ScanSource, EveryLogFormatLocalizesToTheLiveSimPose) {
  const Recorded& r = recorded();
  const fs::path d = temp_dir();
  r.live.write((d / "sweep.scanlog").string());
  write_ros1_bag((d / "sweep.bag").string(), r.live);
  fs::remove_all(d / "sweep_ros2");
  write_ros2_bag((d / "sweep_ros2").string(), r.live);
  ASSERT_TRUE(fs::exists(d / "sweep_ros2" / "metadata.yaml"));
  fs::remove_all(d / "sweep_mcap");
  write_ros2_bag((d / "sweep_mcap").string(), r.live, 1.7e9, Ros2Storage::kMcap);
  const std::pair<std::string, std::string> logs[] = {
      {"sweep.scanlog", "sim"},  {"sweep.bag", "rosbag1"},
      {"sweep_ros2", "rosbag2"}, {"sweep_ros2/sweep_ros2_0.db3", "rosbag2"},
      {"sweep_mcap", "rosbag2"}, {"sweep_mcap/sweep_mcap_0.mcap", "rosbag2"}};
  for (const auto& [name, kind] : logs) {
    SCOPED_TRACE(name);
    const auto source = make_scan_source("log:" + (d / name).string(), r.cell.robot, SimScanInputs());
    const ScanLog log = source->acquire();
    EXPECT_EQ(log.source, kind);
    ASSERT_EQ(log.samples.size(), r.live.samples.size());
    ASSERT_EQ(log.joints.size(), r.live.joints.size());
    // The alignment: every sample keeps its time against the joint states (the zero may move).
    const double shift = log.joints.front().t_s - r.live.joints.front().t_s;
    for (size_t i = 0; i < log.samples.size(); i += 997) {
      // Bit for bit: the A2's 125 us increment is whole nanoseconds, a full turn's angle step is 2 pi / n.
      EXPECT_NEAR(log.samples[i].t_s - r.live.samples[i].t_s, shift, 1e-12) << i;
      EXPECT_EQ(log.samples[i].angle_rad, r.live.samples[i].angle_rad) << i;
      EXPECT_EQ(log.samples[i].range_m, r.live.samples[i].range_m) << i;
      EXPECT_EQ(log.samples[i].quality, r.live.samples[i].quality) << i;
    }
    const Iso3 pose = r.localize_log(log);
    EXPECT_LT((pose.translation() - r.live_pose.translation()).norm(), 1e-6);
    EXPECT_LT(Eigen::AngleAxisd(pose.linear().transpose() * r.live_pose.linear()).angle(), 1e-6);
  }
}

TEST(ScanSource, AnMcapBagGivesTheSqliteBagsCloudBitForBit) {
  const Recorded& r = recorded();
  const fs::path d = temp_dir();
  fs::remove_all(d / "bit_sqlite");
  fs::remove_all(d / "bit_mcap");
  write_ros2_bag((d / "bit_sqlite").string(), r.live);
  write_ros2_bag((d / "bit_mcap").string(), r.live, 1.7e9, Ros2Storage::kMcap);
  const AssembledCloud a =
      assemble_scan(read_ros2_bag((d / "bit_sqlite").string(), r.cell.robot), r.cell.robot);
  const AssembledCloud b =
      assemble_scan(read_ros2_bag((d / "bit_mcap").string(), r.cell.robot), r.cell.robot);
  ASSERT_EQ(a.points_base.size(), b.points_base.size());
  ASSERT_GT(a.points_base.size(), 10000u);
  size_t differ = 0;
  for (size_t i = 0; i < a.points_base.size(); ++i) differ += a.points_base[i] != b.points_base[i];
  EXPECT_EQ(differ, 0u);
}

TEST(ScanSource, ATfOnlyRecordingGivesItsJointStatesTwinsCloud) {
  // A cell that records the arm as robot_state_publisher's /tf (no /joint_states): the joint angles are read
  // back from the links' transforms. At the joint states' own stamps nothing is interpolated, so the cloud
  // is its joint-state twin's up to rounding, in every bag format.
  const Recorded& r = recorded();
  const fs::path d = temp_dir();
  const RobotModel& robot = r.cell.robot;
  const AssembledCloud twin = assemble_scan(r.live, robot);
  fs::remove_all(d / "tf_sqlite");
  fs::remove_all(d / "tf_mcap");
  write_ros1_bag((d / "tf.bag").string(), r.live, 1.7e9, &robot);
  write_ros2_bag((d / "tf_sqlite").string(), r.live, 1.7e9, Ros2Storage::kSqlite3, &robot);
  write_ros2_bag((d / "tf_mcap").string(), r.live, 1.7e9, Ros2Storage::kMcap, &robot);
  const std::pair<const char*, ScanLog> logs[] = {
      {"ROS 1", read_ros1_bag((d / "tf.bag").string(), robot)},
      {"ROS 2 sqlite3", read_ros2_bag((d / "tf_sqlite").string(), robot)},
      {"ROS 2 MCAP", read_ros2_bag((d / "tf_mcap").string(), robot)}};
  for (const auto& [what, log] : logs) {
    ASSERT_EQ(log.joints.size(), r.live.joints.size()) << what;
    double dq = 0;
    for (size_t k = 0; k < log.joints.size(); ++k)
      dq = std::max(dq, (log.joints[k].q - r.live.joints[k].q).cwiseAbs().maxCoeff());
    EXPECT_LT(dq, 1e-9) << what;
    const AssembledCloud a = assemble_scan(log, robot);
    ASSERT_EQ(a.points_base.size(), twin.points_base.size()) << what;
    double dp = 0;
    for (size_t i = 0; i < a.points_base.size(); ++i)
      dp = std::max(dp, static_cast<double>((a.points_base[i] - twin.points_base[i]).norm()));
    EXPECT_LT(dp, 1e-6) << what << ": the cloud moved";
  }
  // Transforms of another robot (a joint's origin 5 mm elsewhere) are not this robot's joints.
  std::string moved;
  for (const RobotLink& l : robot.links())
    if (l.q_index == 2) moved = l.name;
  const RobotModel other = robot.with_mount_offset(moved, planar_pose(0.005, 0, 0, 0));
  write_ros1_bag((d / "tf_other.bag").string(), r.live, 1.7e9, &other);
  try {
    read_ros1_bag((d / "tf_other.bag").string(), robot);
    ADD_FAILURE() << "another robot's transforms were read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is not the robot's joint"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("5.00 mm from its origin"), std::string::npos) << e.what();
  }
}

TEST(ScanSource, RosbagsOwnMcapTestBagIsReadAndRefusedForWhatItLacks) {
  // rosbag2's own MCAP test bag (tests/data/README.md): zstd chunks, a schema per type.
  const std::string path = test::repo("tests/data/rosbag2_talker_mcap/talker.mcap");
  const mcap::File f = mcap::read(path);
  EXPECT_EQ(f.profile, "ros2");
  std::map<std::string, std::pair<std::string, int>> topics;
  for (const auto& [id, ch] : f.channels) topics[ch.topic] = {ch.schema_name, 0};
  for (const mcap::Message& m : f.messages) ++topics[f.channels.at(m.channel).topic].second;
  EXPECT_EQ(topics["/topic"], std::make_pair(std::string("std_msgs/msg/String"), 10));
  EXPECT_EQ(topics["/rosout"], std::make_pair(std::string("rcl_interfaces/msg/Log"), 10));
  try {
    read_ros2_bag(test::repo("tests/data/rosbag2_talker_mcap"), recorded().cell.robot);
    ADD_FAILURE() << "a bag without laser scans was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no sensor_msgs/LaserScan messages"), std::string::npos) << e.what();
  }
}

TEST(ScanSource, BrokenMcapFilesAreRefusedWithTheReason) {
  const fs::path d = temp_dir();
  const std::string good = test::repo("tests/data/rosbag2_talker_mcap/talker.mcap");
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto refusal = [&](const std::string& content) {
    const std::string p = (d / "broken.mcap").string();
    std::ofstream(p, std::ios::binary | std::ios::trunc) << content;
    try {
      mcap::read(p);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("read");
  };
  // Cut short, as a recorder that was killed leaves it.
  EXPECT_NE(refusal(bytes.substr(0, bytes.size() / 2)).find("cut short"), std::string::npos);
  // A byte of the zstd chunk changed: it no longer decompresses, or its CRC says so.
  std::string flipped = bytes;
  flipped[200] = static_cast<char>(flipped[200] ^ 0x5A);
  const std::string e = refusal(flipped);
  EXPECT_TRUE(e.find("does not decompress") != std::string::npos || e.find("CRC") != std::string::npos) << e;
  // The first chunk claims 2^40 bytes uncompressed: refused before anything is allocated.
  std::string bomb = bytes;
  const size_t chunk = 8 + 9 + 28;  // magic, the header record (opcode, length, its 28 bytes)
  ASSERT_EQ(bomb[chunk], 0x06);
  const uint64_t huge = 1ull << 40;
  std::memcpy(&bomb[chunk + 9 + 16], &huge, 8);
  EXPECT_NE(refusal(bomb).find("at most 1 GiB"), std::string::npos) << refusal(bomb);
  EXPECT_NE(refusal("not mcap at all").find("not an MCAP file"), std::string::npos);
}

// One LaserScan's fields as its CDR bytes hold them (read here apart from the reader under test).
struct RawScan {
  int64_t stamp_ns = 0;
  float angle_min = 0, angle_increment = 0, time_increment = 0, range_min = 0, range_max = 0;
  std::vector<float> ranges;
  size_t ranges_at = 0;  // byte offset of ranges[0] in the blob
};

RawScan raw_scan(const std::string& blob) {
  // 4 bytes of encapsulation; then, aligned from there: stamp (int32 s, uint32 ns), frame_id (uint32 length
  // with its NUL, the chars), 7 float32 (angle_min, angle_max, angle_increment, time_increment, scan_time,
  // range_min, range_max), ranges (uint32 count, float32s).
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, blob.data() + 4 + at, 4);
    return v;
  };
  auto f32 = [&](size_t at) {
    float v = 0;
    std::memcpy(&v, blob.data() + 4 + at, 4);
    return v;
  };
  RawScan s;
  s.stamp_ns = int64_t{static_cast<int32_t>(u32(0))} * 1000000000 + u32(4);
  size_t at = 12 + u32(8);
  at = (at + 3) / 4 * 4;
  s.angle_min = f32(at);
  s.angle_increment = f32(at + 8);
  s.time_increment = f32(at + 12);
  s.range_min = f32(at + 20);
  s.range_max = f32(at + 24);
  const uint32_t n = u32(at + 28);
  s.ranges_at = 4 + at + 32;
  for (uint32_t i = 0; i < n; ++i) s.ranges.push_back(f32(at + 32 + 4 * i));
  return s;
}

TEST(ScanSource, ARealRplidarRosBagsNoReturnsAreReadAsTheDriverMeansThem) {
  // Slamtec's rplidar_ros publishes inf for a beam with no return; micro-ROS publishers send 0; some drivers
  // send a range beyond range_max (or below range_min) for "nothing there". Every one is no return (range 0);
  // every other beam is kept bit for bit, at its angle and time. The real bag holds only /scan: joint states
  // from our writer are added to a copy, stamped over the same span.
  const std::string real = test::real_data("bags/ros2_rplidar_scans/rosbag2_2025_05_08-14_24_05_0.db3");
  if (!fs::exists(real)) GTEST_SKIP() << "skipped: ../shared/real not found (" << real << ")";
  const RobotModel robot = load_cell_robot(CellSpec::load(test::repo("scenes/cells/default.yaml")));
  const fs::path d = temp_dir() / "rplidar_ros";
  fs::remove_all(d);
  fs::create_directories(d);
  const fs::path copy = d / "scans.db3";
  fs::copy_file(real, copy);

  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(copy.string().c_str(), &db), SQLITE_OK);
  std::vector<std::pair<int64_t, std::string>> blobs;  // (row id, data), in time order
  {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, "SELECT id, data FROM messages ORDER BY timestamp", -1, &st, nullptr);
    while (sqlite3_step(st) == SQLITE_ROW)
      blobs.emplace_back(sqlite3_column_int64(st, 0),
                         std::string(static_cast<const char*>(sqlite3_column_blob(st, 1)),
                                     static_cast<size_t>(sqlite3_column_bytes(st, 1))));
    sqlite3_finalize(st);
  }
  ASSERT_EQ(blobs.size(), 420u);
  // The first scan's first beams as micro-ROS and other drivers would send "no return".
  RawScan first = raw_scan(blobs[0].second);
  const float planted[] = {0.0f, first.range_max * 1.5f, first.range_min * 0.5f,
                           std::numeric_limits<float>::quiet_NaN(), -1.0f};
  for (size_t k = 0; k < std::size(planted); ++k)
    std::memcpy(&blobs[0].second[first.ranges_at + 4 * k], &planted[k], 4);
  {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, "UPDATE messages SET data = ? WHERE id = ?", -1, &st, nullptr);
    sqlite3_bind_blob(st, 1, blobs[0].second.data(), static_cast<int>(blobs[0].second.size()), SQLITE_STATIC);
    sqlite3_bind_int64(st, 2, blobs[0].first);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_finalize(st);
  }
  std::vector<RawScan> scans;
  for (const auto& b : blobs) scans.push_back(raw_scan(b.second));
  // Joint states at 100 Hz from 1 s before the first scan to 1 s after the last.
  ScanLog joints;
  joints.joint_names = robot.joint_names();
  const double span_s = static_cast<double>(scans.back().stamp_ns - scans.front().stamp_ns) / 1e9;
  for (double t = 0; t <= span_s + 2.0; t += 0.01) joints.joints.push_back({t, JointVector::Zero()});
  write_ros2_bag((d / "joints").string(), joints, static_cast<double>(scans.front().stamp_ns) / 1e9 - 1.0);
  const std::string attach =
      "ATTACH '" + (d / "joints" / "joints_0.db3").string() +
      "' AS j; INSERT INTO topics SELECT * FROM j.topics WHERE id = 2;"
      "INSERT INTO messages (topic_id, timestamp, data) SELECT topic_id, timestamp, data "
      "FROM j.messages WHERE topic_id = 2;";
  ASSERT_EQ(sqlite3_exec(db, attach.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);

  const ScanLog log = read_ros2_bag(copy.string(), robot);
  ASSERT_EQ(log.turns.size(), scans.size());
  const double first_s = log.samples[log.turns[0].first].t_s;  // times relative to the first scan's stamp
  size_t infinite = 0, kept = 0, none = 0;
  for (size_t k = 0; k < scans.size(); ++k) {
    const RawScan& m = scans[k];
    const LidarTurn& turn = log.turns[k];
    ASSERT_EQ(turn.count, m.ranges.size()) << "scan " << k;
    for (size_t i = 0; i < m.ranges.size(); ++i) {
      const LidarSample& s = log.samples[turn.first + i];
      const float r = m.ranges[i];
      infinite += std::isinf(r);
      const bool ret = std::isfinite(r) && r > 0 && r >= m.range_min && r <= m.range_max;
      if (ret) {
        ++kept;
        ASSERT_EQ(s.range_m, r) << "scan " << k << " beam " << i;
        EXPECT_GT(s.quality, 0) << "scan " << k << " beam " << i;
      } else {
        ++none;
        ASSERT_EQ(s.range_m, 0.0f) << "scan " << k << " beam " << i << ": " << r << " must be no return";
        EXPECT_EQ(s.quality, 0);
      }
      double a =
          std::fmod(static_cast<double>(m.angle_min) + static_cast<double>(i) * m.angle_increment, 2 * kPi);
      if (a < 0) a += 2 * kPi;
      const double da = std::abs(a - s.angle_rad);
      EXPECT_LT(std::min(da, 2 * kPi - da), 1e-5) << "scan " << k << " beam " << i;
      const double t = static_cast<double>(m.stamp_ns - scans.front().stamp_ns) / 1e9 +
                       static_cast<double>(i) * m.time_increment;
      EXPECT_NEAR(s.t_s - first_s, t, 1e-6) << "scan " << k << " beam " << i;
    }
  }
  EXPECT_GT(infinite, 1000u) << "the real bag's own no-returns (inf)";
  EXPECT_GT(kept, 100000u);
  EXPECT_GE(none, infinite + 4);  // and the planted ones (one of them is not finite either)
}

TEST(ScanSource, JointStatesAreReorderedByNameAndTheirTimesKept) {
  // A bag whose joint states list the joints in another order and start before the first scan.
  const Recorded& r = recorded();
  ScanLog log = r.live;
  log.joint_names = {log.joint_names[5], log.joint_names[4], log.joint_names[3],
                     log.joint_names[2], log.joint_names[1], log.joint_names[0]};
  for (JointState& s : log.joints) s.q = s.q.reverse().eval();
  const fs::path bag = temp_dir() / "reordered.bag";
  write_ros1_bag(bag.string(), log);
  const ScanLog back = read_ros1_bag(bag.string(), r.cell.robot);
  ASSERT_EQ(back.joints.size(), r.live.joints.size());
  for (size_t k = 0; k < back.joints.size(); k += 101)
    EXPECT_LT((back.joints[k].q - r.live.joints[k].q).cwiseAbs().maxCoeff(), 1e-12) << k;
  EXPECT_EQ(back.joint_names, r.cell.robot.joint_names());
}

TEST(ScanSource, BadInputIsRefusedNamingTheFile) {
  const Recorded& r = recorded();
  const fs::path d = temp_dir();
  auto refused = [&](const std::string& spec, const std::string& words) {
    try {
      make_scan_source(spec, r.cell.robot, SimScanInputs())->acquire();
      ADD_FAILURE() << spec << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  std::ofstream(d / "garbage.bag") << "#ROSBAG V2.0\nnot a bag at all";
  refused("log:" + (d / "garbage.bag").string(), "garbage.bag");
  std::ofstream(d / "text.txt") << "hello";
  refused("log:" + (d / "text.txt").string(), "not a recorded sweep");
  refused("log:" + (d / "missing.bag").string(), "no such file");
  fs::create_directories(d / "empty_ros2");
  refused("log:" + (d / "empty_ros2").string(), "without a .db3");
  refused("lidar:/dev/ttyUSB9", "needs the arm that carries the LiDAR");
  refused("lidar:", "needs a serial port");
  refused("camera", "not sim, log:FILE or lidar:DEV");
  // A bag without joint states.
  ScanLog no_joints = r.live;
  no_joints.joints.clear();
  write_ros1_bag((d / "scans_only.bag").string(), no_joints);
  refused("log:" + (d / "scans_only.bag").string(),
          "no sensor_msgs/JointState messages and no tf2_msgs/TFMessage");
  // A LaserScan whose beams are seconds apart (fuzz_ros_bag's finding: a time_increment of 1e19 s had
  // overflowed the beams' nanoseconds).
  ScanLog slow = r.live;
  slow.turns.resize(1);
  slow.samples.resize(slow.turns[0].count);
  for (size_t i = 0; i < slow.samples.size(); ++i) slow.samples[i].t_s = 2.0 * static_cast<double>(i);
  write_ros1_bag((d / "slow.bag").string(), slow);
  refused("log:" + (d / "slow.bag").string(), "beams are 2 s apart (time_increment): not a scanning LiDAR");
  // Bags whose offsets send rosbag into the middle of a record (it allocated the 3.8 GB length it read there;
  // fuzz_ros_bag's finding): the version line run on past its newline, the index position moved by a byte.
  write_ros1_bag((d / "whole.bag").string(), r.live);
  std::ifstream whole_in(d / "whole.bag", std::ios::binary);
  const std::string whole((std::istreambuf_iterator<char>(whole_in)), std::istreambuf_iterator<char>());
  auto mutant = [&](const std::string& name, const std::function<void(std::string&)>& change) {
    std::string b = whole;
    change(b);
    std::ofstream(d / name, std::ios::binary | std::ios::trunc) << b;
    return "log:" + (d / name).string();
  };
  refused(mutant("no_newline.bag", [](std::string& b) { b[12] = '\0'; }), "a ROS 1 bag of version ?");
  refused(mutant("v12.bag", [](std::string& b) { b.replace(9, 3, "1.2"); }), "a ROS 1 bag of version 1.2");
  std::ofstream(d / "old.bag") << "#ROSRECORD V1.2\n\x1e\0\0\0";
  refused("log:" + (d / "old.bag").string(), "a ROS 1 bag of version 1.2");
  refused(mutant("index_pos.bag",
                 [](std::string& b) {
                   const size_t at = b.find("index_pos=");
                   ASSERT_NE(at, std::string::npos);
                   uint64_t pos = 0;
                   std::memcpy(&pos, &b[at + 10], 8);
                   ++pos;
                   std::memcpy(&b[at + 10], &pos, 8);
                 }),
          "the bag's index position is not on a record");
  // A ROS 2 bag whose messages are cut short.
  fs::remove_all(d / "cut");
  write_ros2_bag((d / "cut").string(), r.live);
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((d / "cut" / "cut_0.db3").string().c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE messages SET data = substr(data, 1, 40)", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  refused("log:" + (d / "cut").string(), "truncated CDR");
  // A ROS 2 topic with no name (a NULL in the database had been dereferenced).
  fs::remove_all(d / "noname");
  write_ros2_bag((d / "noname").string(), r.live);
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((d / "noname" / "noname_0.db3").string().c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db,
                           "CREATE TABLE t AS SELECT * FROM topics; DROP TABLE topics; "
                           "CREATE TABLE topics AS SELECT * FROM t; UPDATE topics SET name = NULL",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  refused("log:" + (d / "noname").string(), "a topic without a name");
  // A ROS 1 LaserScan whose ranges claim 2^30 floats in a message of a few kilobytes (rosbag had allocated
  // them: 5 GiB in 3 s): refused before it is deserialised.
  const std::string bag = (d / "huge_ranges.bag").string();
  write_ros1_bag(bag, r.live);
  std::string bytes;
  {
    std::ifstream in(bag, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string& frame = r.live.lidar_frame;
  std::string needle(4, '\0');
  const uint32_t len = static_cast<uint32_t>(frame.size());
  std::memcpy(needle.data(), &len, 4);
  needle += frame;
  const size_t at = bytes.find(needle);
  ASSERT_NE(at, std::string::npos);
  const size_t count_at = at + needle.size() + 7 * 4;  // past the frame and the seven floats
  uint32_t ranges = 0;
  std::memcpy(&ranges, bytes.data() + count_at, 4);
  ASSERT_EQ(ranges, r.live.turns.front().count);  // the first scan's ranges, as written
  const uint32_t huge = 1u << 30;
  std::memcpy(bytes.data() + count_at, &huge, 4);
  std::ofstream(bag, std::ios::binary) << bytes;
  refused("log:" + bag, "claims 1073741824 elements");
  // One index record's entry count raised by 1 (rosbag had read past the record and crashed): the records no
  // longer line up, refused before rosbag opens the file.
  const std::string index_bag = (d / "index_count.bag").string();
  write_ros1_bag(index_bag, r.live);
  {
    std::ifstream in(index_bag, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const size_t op = bytes.find(std::string("op=\x04", 4));
  ASSERT_NE(op, std::string::npos);
  const size_t count = bytes.rfind("count=", op);
  ASSERT_TRUE(count != std::string::npos && op - count < 64);
  uint32_t entries = 0;
  std::memcpy(&entries, bytes.data() + count + 6, 4);
  ++entries;
  std::memcpy(bytes.data() + count + 6, &entries, 4);
  std::ofstream(index_bag, std::ios::binary) << bytes;
  refused("log:" + index_bag, "index_count.bag");
}

}  // namespace
}  // namespace weldtwin
