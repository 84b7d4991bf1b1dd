#include "hw/ros_bags.hpp"

#include <bzlib.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <sqlite3.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "core/error.hpp"
#include "core/files.hpp"
#include "hw/mcap.hpp"
#include "hw/tf_joints.hpp"

namespace weldtwin {
namespace {

constexpr double kTwoPi = 2.0 * kPi;
constexpr double kMaxBeamInterval_s = 1.0;  // a LaserScan's time_increment must be shorter

// The two messages, whatever the bag: what a ScanLog needs of them.
struct ScanMsg {
  int64_t stamp_ns = 0;
  float angle_min = 0, angle_increment = 0, time_increment = 0, range_min = 0, range_max = 0;
  std::vector<float> ranges, intensities;
};

struct JointMsg {
  int64_t stamp_ns = 0;
  std::vector<std::string> names;
  std::vector<double> position;
};

ScanLog to_scan_log(std::vector<ScanMsg> scans, std::vector<JointMsg> joints, const RobotModel& robot,
                    const std::string& source, const std::string& file) {
  if (scans.empty()) throw input_error(file, "no sensor_msgs/LaserScan messages");
  if (joints.empty())
    throw input_error(file,
                      "no arm poses: no sensor_msgs/JointState messages and no tf2_msgs/TFMessage on /tf");
  auto by_stamp = [](const auto& a, const auto& b) { return a.stamp_ns < b.stamp_ns; };
  std::stable_sort(scans.begin(), scans.end(), by_stamp);
  std::stable_sort(joints.begin(), joints.end(), by_stamp);
  const int64_t t0 = std::min(scans.front().stamp_ns, joints.front().stamp_ns);
  ScanLog log;
  log.source = source;
  log.robot = robot.name();
  log.joint_names = robot.joint_names();
  for (const ScanMsg& m : scans) {
    if (!std::isfinite(m.angle_min) || !std::isfinite(m.angle_increment) || !std::isfinite(m.time_increment))
      throw input_error(file, "a LaserScan with a non-finite angle or time increment");
    // A scanning LiDAR's beams follow each other by microseconds (the A2's 125 us); a second or more between
    // two beams is not a LiDAR's recording (and its nanoseconds would overflow below).
    if (std::abs(m.time_increment) >= kMaxBeamInterval_s) {
      char b[160];
      std::snprintf(b, sizeof b,
                    "a LaserScan whose beams are %.3g s apart (time_increment): not a scanning LiDAR",
                    static_cast<double>(m.time_increment));
      throw input_error(file, b);
    }
    const bool have_quality =
        m.intensities.size() == m.ranges.size() &&
        std::any_of(m.intensities.begin(), m.intensities.end(), [](float v) { return v > 0.0f; });
    LidarTurn turn;
    const int64_t start_ns = m.stamp_ns - t0;
    turn.t_start_s = static_cast<double>(start_ns) / 1e9;
    turn.first = static_cast<uint32_t>(log.samples.size());
    turn.count = static_cast<uint32_t>(m.ranges.size());
    // A time increment that is a whole number of nanoseconds as far as float32 tells (the A2's 125 us) is
    // taken as exactly that, and a full turn's angle increment as exactly 2 pi / n: then a sweep recorded
    // from the twin comes back bit for bit.
    const double inc_ns = static_cast<double>(m.time_increment) * 1e9;
    const bool whole_ns = std::abs(inc_ns - std::round(inc_ns)) < 0.01;
    const int64_t step_ns = std::llround(inc_ns);
    const double n = static_cast<double>(m.ranges.size());
    double angle_step = static_cast<double>(m.angle_increment);
    if (m.ranges.size() > 1 && std::abs(n * angle_step - kTwoPi) < 1e-4) angle_step = kTwoPi / n;
    for (size_t i = 0; i < m.ranges.size(); ++i) {
      LidarSample s;
      const double k = static_cast<double>(i);
      s.t_s = whole_ns ? static_cast<double>(start_ns + static_cast<int64_t>(i) * step_ns) / 1e9
                       : turn.t_start_s + k * static_cast<double>(m.time_increment);
      double a = static_cast<double>(m.angle_min) + k * angle_step;
      a = std::fmod(a, kTwoPi);
      if (a < 0) a += kTwoPi;
      s.angle_rad = static_cast<float>(a);
      if (s.angle_rad >= static_cast<float>(kTwoPi)) s.angle_rad = 0.0f;
      const float r = m.ranges[i];
      const bool valid = std::isfinite(r) && r > 0.0f && r >= m.range_min && r <= m.range_max;
      s.range_m = valid ? r : 0.0f;
      s.quality = !valid         ? 0
                  : have_quality ? static_cast<uint8_t>(std::clamp(std::lround(m.intensities[i]), 1l, 255l))
                                 : 255;
      log.samples.push_back(s);
    }
    log.turns.push_back(turn);
  }
  std::vector<int> column;  // robot joint j is message entry column[j]
  for (const JointMsg& m : joints) {
    if (m.names.size() != m.position.size())
      throw input_error(file, "a JointState with " + std::to_string(m.names.size()) + " names and " +
                                  std::to_string(m.position.size()) + " positions");
    column.assign(robot.joint_names().size(), -1);
    for (size_t j = 0; j < robot.joint_names().size(); ++j)
      for (size_t k = 0; k < m.names.size(); ++k)
        if (m.names[k] == robot.joint_names()[j]) column[j] = static_cast<int>(k);
    for (size_t j = 0; j < column.size(); ++j)
      if (column[j] < 0)
        throw input_error(file, "a JointState without joint '" + robot.joint_names()[j] + "' of robot '" +
                                    robot.name() + "'");
    JointState s;
    s.t_s = static_cast<double>(m.stamp_ns - t0) / 1e9;
    for (size_t j = 0; j < column.size(); ++j)
      s.q[static_cast<int>(j)] = m.position[static_cast<size_t>(column[j])];
    if (!s.q.allFinite()) throw input_error(file, "a JointState with a non-finite position");
    if (!log.joints.empty() && s.t_s <= log.joints.back().t_s) continue;  // a repeated stamp: keep the first
    log.joints.push_back(s);
  }
  return log;
}

/// Joint states from /tf transforms (when a recording has no JointState topic).
std::vector<JointMsg> joints_of_tf(const std::vector<TfTransform>& tf, const RobotModel& robot,
                                   const std::string& file) {
  std::vector<JointMsg> out;
  if (tf.empty()) return out;
  for (const StampedJoints& j : joints_from_tf(tf, robot, file)) {
    JointMsg m;
    m.stamp_ns = j.stamp_ns;
    m.names = robot.joint_names();
    m.position.assign(j.q.data(), j.q.data() + j.q.size());
    out.push_back(std::move(m));
  }
  return out;
}

int64_t to_ns(double seconds) {
  return std::llround(seconds * 1e9);
}

// The messages of a ScanLog: a LaserScan per turn (evenly spaced angles and times, as a LaserScan holds
// them), a JointState per joint state.
void from_scan_log(const ScanLog& log, double epoch_s, std::vector<ScanMsg>& scans,
                   std::vector<JointMsg>& joints) {
  const int64_t epoch = to_ns(epoch_s);
  float lo = 0.15f, hi = 12.0f;
  for (const LidarSample& s : log.samples)
    if (s.range_m > 0) lo = std::min(lo, s.range_m), hi = std::max(hi, s.range_m);
  for (size_t k = 0; k < log.turns.size(); ++k) {
    const LidarTurn& turn = log.turns[k];
    if (turn.count == 0) continue;
    const LidarSample* s = &log.samples[turn.first];
    ScanMsg m;
    m.stamp_ns = epoch + to_ns(s[0].t_s);
    m.angle_min = s[0].angle_rad;
    if (turn.count > 1) {
      double da = static_cast<double>(s[1].angle_rad) - s[0].angle_rad;
      if (da < 0) da += kTwoPi;
      m.angle_increment = static_cast<float>(da);
      m.time_increment = static_cast<float>(s[1].t_s - s[0].t_s);
    }
    for (uint32_t i = 0; i < turn.count; ++i) {
      double a = static_cast<double>(m.angle_min) + i * static_cast<double>(m.angle_increment);
      a = std::fmod(a, kTwoPi);
      double off = std::abs(a - s[i].angle_rad);
      off = std::min(off, kTwoPi - off);
      const double dt = std::abs(s[0].t_s + i * static_cast<double>(m.time_increment) - s[i].t_s);
      if (off > 1e-5 || dt > 1e-7)
        throw std::runtime_error("turn " + std::to_string(k) +
                                 " has unevenly spaced samples: a LaserScan cannot hold it");
      m.ranges.push_back(s[i].range_m > 0 ? s[i].range_m : std::numeric_limits<float>::infinity());
      m.intensities.push_back(static_cast<float>(s[i].quality));
    }
    m.range_min = lo;
    m.range_max = hi;
    scans.push_back(std::move(m));
  }
  for (const JointState& j : log.joints) {
    JointMsg m;
    m.stamp_ns = epoch + to_ns(j.t_s);
    m.names = log.joint_names;
    for (int k = 0; k < j.q.size(); ++k) m.position.push_back(j.q[k]);
    joints.push_back(std::move(m));
  }
}

// --- ROS 1 ---

ros::Time ros_time(int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

/// `t` with the transform of translation v[0..2] and rotation quaternion v[3..6] (x y z w), checked finite
/// and unit (within 1 %, then normalised).
TfTransform tf_transform(TfTransform t, const double v[7], const std::string& file) {
  for (int i = 0; i < 7; ++i)
    if (!std::isfinite(v[i])) throw input_error(file, "a /tf transform with a non-finite value");
  const Quat q(v[6], v[3], v[4], v[5]);
  if (std::abs(q.norm() - 1.0) > 0.01)
    throw input_error(file, "a /tf transform whose rotation is not a unit quaternion (norm " +
                                std::to_string(q.norm()) + ")");
  t.T_parent_child = Iso3::Identity();
  t.T_parent_child.linear() = q.normalized().toRotationMatrix();
  t.T_parent_child.translation() = Vec3(v[0], v[1], v[2]);
  return t;
}

// --- CDR (ROS 2's serialization): little- or big-endian, alignment from the end of the 4-byte header ---

class CdrReader {
 public:
  CdrReader(const uint8_t* data, size_t size, const std::string& file) : p_(data), n_(size), file_(file) {
    if (n_ < 4 || p_[0] != 0 || p_[1] > 1) throw input_error(file_, "a message that is not CDR");
    little_ = p_[1] == 1;
    pos_ = 4;
  }
  template <typename T>
  T get() {
    align(sizeof(T));
    need(sizeof(T));
    uint8_t b[sizeof(T)];
    std::memcpy(b, p_ + pos_, sizeof(T));
    if (!little_) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string str() {
    const uint32_t len = get<uint32_t>();
    need(len);
    std::string s(reinterpret_cast<const char*>(p_ + pos_), len > 0 ? len - 1 : 0);
    pos_ += len;
    return s;
  }
  template <typename T>
  std::vector<T> seq() {
    const uint32_t count = get<uint32_t>();
    if (count > n_) throw input_error(file_, "a CDR sequence longer than its message");
    std::vector<T> v(count);
    for (T& x : v) x = get<T>();
    return v;
  }

 private:
  void align(size_t a) { pos_ = 4 + (pos_ - 4 + a - 1) / a * a; }
  void need(size_t k) {
    if (pos_ + k > n_) throw input_error(file_, "a truncated CDR message");
  }
  const uint8_t* p_;
  size_t n_, pos_ = 4;
  std::string file_;
  bool little_ = true;
};

class CdrWriter {
 public:
  CdrWriter() : b_{0, 1, 0, 0} {}  // CDR, little-endian
  template <typename T>
  void put(T v) {
    while ((b_.size() - 4) % sizeof(T) != 0) b_.push_back(0);
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    b_.insert(b_.end(), p, p + sizeof(T));
  }
  void str(const std::string& s) {
    put<uint32_t>(static_cast<uint32_t>(s.size() + 1));
    b_.insert(b_.end(), s.begin(), s.end());
    b_.push_back(0);
  }
  template <typename T>
  void seq(const std::vector<T>& v) {
    put<uint32_t>(static_cast<uint32_t>(v.size()));
    for (const T& x : v) put<T>(x);
  }
  const std::vector<uint8_t>& bytes() const { return b_; }

 private:
  std::vector<uint8_t> b_;
};

int64_t cdr_stamp(CdrReader& r) {
  const int32_t sec = r.get<int32_t>();
  const uint32_t nsec = r.get<uint32_t>();
  r.str();  // frame_id
  return static_cast<int64_t>(sec) * 1000000000 + nsec;
}

void cdr_header(CdrWriter& w, int64_t ns, const std::string& frame) {
  w.put<int32_t>(static_cast<int32_t>(ns / 1000000000));
  w.put<uint32_t>(static_cast<uint32_t>(ns % 1000000000));
  w.str(frame);
}

constexpr const char* kLaserScanType = "sensor_msgs/msg/LaserScan";
constexpr const char* kJointStateType = "sensor_msgs/msg/JointState";
constexpr const char* kTfType = "tf2_msgs/msg/TFMessage";
constexpr size_t kCdrTransformBytes = 4 + 4 + 4 + 4 + 7 * 8;  // the least a TransformStamped takes

/// A TFMessage's transforms, appended to `out`.
void cdr_tf_message(const uint8_t* data, size_t size, const std::string& file,
                    std::vector<TfTransform>& out) {
  CdrReader r(data, size, file);
  const uint32_t n = r.get<uint32_t>();
  if (n > size / kCdrTransformBytes)
    throw input_error(
        file, "a TFMessage of " + std::to_string(n) + " transforms in " + std::to_string(size) + " bytes");
  for (uint32_t k = 0; k < n; ++k) {
    TfTransform t;
    const int32_t sec = r.get<int32_t>();
    const uint32_t nsec = r.get<uint32_t>();
    t.stamp_ns = static_cast<int64_t>(sec) * 1000000000 + nsec;
    t.parent = r.str();
    t.child = r.str();
    double v[7];
    for (double& x : v) x = r.get<double>();
    out.push_back(tf_transform(t, v, file));
  }
}

ScanMsg cdr_laser_scan(const uint8_t* data, size_t size, const std::string& file) {
  CdrReader r(data, size, file);
  ScanMsg m;
  m.stamp_ns = cdr_stamp(r);
  m.angle_min = r.get<float>();
  r.get<float>();  // angle_max
  m.angle_increment = r.get<float>();
  m.time_increment = r.get<float>();
  r.get<float>();  // scan_time
  m.range_min = r.get<float>();
  m.range_max = r.get<float>();
  m.ranges = r.seq<float>();
  m.intensities = r.seq<float>();
  return m;
}

JointMsg cdr_joint_state(const uint8_t* data, size_t size, const std::string& file) {
  CdrReader r(data, size, file);
  JointMsg m;
  m.stamp_ns = cdr_stamp(r);
  const uint32_t names = r.get<uint32_t>();
  if (names > 1000) throw input_error(file, "a JointState with " + std::to_string(names) + " names");
  for (uint32_t k = 0; k < names; ++k) m.names.push_back(r.str());
  m.position = r.seq<double>();
  return m;
}

std::vector<uint8_t> cdr_of(const ScanMsg& m, const std::string& frame) {
  CdrWriter w;
  cdr_header(w, m.stamp_ns, frame);
  w.put<float>(m.angle_min);
  w.put<float>(m.angle_min + m.angle_increment * static_cast<float>(m.ranges.size() - 1));
  w.put<float>(m.angle_increment);
  w.put<float>(m.time_increment);
  w.put<float>(m.time_increment * static_cast<float>(m.ranges.size()));
  w.put<float>(m.range_min);
  w.put<float>(m.range_max);
  w.seq(m.ranges);
  w.seq(m.intensities);
  return w.bytes();
}

std::vector<uint8_t> cdr_of(const std::vector<TfTransform>& tf) {
  CdrWriter w;
  w.put<uint32_t>(static_cast<uint32_t>(tf.size()));
  for (const TfTransform& t : tf) {
    cdr_header(w, t.stamp_ns, t.parent);
    w.str(t.child);
    const Vec3 p = t.T_parent_child.translation();
    const Quat q(t.T_parent_child.rotation());
    for (const double x : {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()}) w.put<double>(x);
  }
  return w.bytes();
}

std::vector<uint8_t> cdr_of(const JointMsg& m) {
  CdrWriter w;
  cdr_header(w, m.stamp_ns, "");
  w.put<uint32_t>(static_cast<uint32_t>(m.names.size()));
  for (const std::string& n : m.names) w.str(n);
  w.seq(m.position);
  w.seq(std::vector<double>());  // velocity
  w.seq(std::vector<double>());  // effort
  return w.bytes();
}

/// The transforms of a joint state's moving joints, as robot_state_publisher publishes them on /tf.
std::vector<TfTransform> tf_of(const JointMsg& m, const RobotModel& robot) {
  JointVector q = JointVector::Zero();
  for (size_t k = 0; k < m.names.size(); ++k) {
    const auto& names = robot.joint_names();
    const auto it = std::find(names.begin(), names.end(), m.names[k]);
    if (it == names.end()) throw std::runtime_error("the robot has no joint '" + m.names[k] + "'");
    q[static_cast<int>(it - names.begin())] = m.position[k];
  }
  return tf_of_joints(m.stamp_ns, q, robot);
}

/// The ROS 2 bag's metadata.yaml, as rosbag2 writes it (its readers check storage_identifier and the files).
void write_ros2_metadata(const std::string& dir, const std::string& storage, const std::string& file,
                         size_t scans, size_t joints, int64_t first, int64_t last,
                         const std::string& arm_topic, const std::string& arm_type) {
  const size_t count = scans + joints;
  std::ofstream meta(std::filesystem::path(dir) / "metadata.yaml");
  meta << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: " << storage
       << "\n  duration:\n    nanoseconds: " << last - first
       << "\n  starting_time:\n    nanoseconds_since_epoch: " << first << "\n  message_count: " << count
       << "\n  topics_with_message_count:\n"
       << "    - topic_metadata:\n        name: /scan\n        type: " << kLaserScanType
       << "\n        serialization_format: cdr\n        offered_qos_profiles: \"\"\n      message_count: "
       << scans << "\n"
       << "    - topic_metadata:\n        name: " << arm_topic << "\n        type: " << arm_type
       << "\n        serialization_format: cdr\n        offered_qos_profiles: \"\"\n      message_count: "
       << joints << "\n  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - "
       << file << "\n  files:\n    - path: " << file
       << "\n      starting_time:\n        nanoseconds_since_epoch: " << first
       << "\n      duration:\n        nanoseconds: " << last - first << "\n      message_count: " << count
       << "\n";
}

// --- sqlite ---

struct Db {
  sqlite3* db = nullptr;
  ~Db() {
    if (db) sqlite3_close(db);
  }
};

struct Stmt {
  sqlite3_stmt* s = nullptr;
  ~Stmt() {
    if (s) sqlite3_finalize(s);
  }
};

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string what = err ? err : "?";
    sqlite3_free(err);
    throw std::runtime_error("sqlite: " + what);
  }
}

/// The storage file of a ROS 2 bag given as its directory or the file itself: one .db3 or one .mcap.
std::string find_ros2_storage(const std::string& path) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(path)) return path;
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(path))
    if (e.path().extension() == ".db3" || e.path().extension() == ".mcap") files.push_back(e.path().string());
  if (files.empty()) throw input_error(path, "a ROS 2 bag directory without a .db3 or .mcap file");
  if (files.size() > 1)
    throw input_error(path, "a ROS 2 bag split into several storage files (not read yet)");
  return files.front();
}

bool is_mcap(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  char head[5] = {};
  in.read(head, 5);
  return in.gcount() == 5 && std::memcmp(head, "\x89MCAP", 5) == 0;
}

ScanLog read_ros2_mcap(const std::string& file, const RobotModel& robot, const BagTopics& topics) {
  const mcap::File bag = mcap::read(file);
  int scan_id = -1, joint_id = -1;
  std::set<int> tf_ids;
  for (const auto& [id, ch] : bag.channels) {
    if (ch.message_encoding != "cdr") continue;
    if (ch.schema_name == kLaserScanType && scan_id < 0 && (topics.scan.empty() || topics.scan == ch.topic))
      scan_id = id;
    if (ch.schema_name == kJointStateType && joint_id < 0 &&
        (topics.joints.empty() || topics.joints == ch.topic))
      joint_id = id;
    if (ch.schema_name == kTfType) tf_ids.insert(id);
  }
  if (joint_id >= 0) tf_ids.clear();  // joint states, where there are any
  std::vector<ScanMsg> scans;
  std::vector<JointMsg> joints;
  std::vector<TfTransform> tf;
  for (const mcap::Message& m : bag.messages) {
    if (m.channel == scan_id) scans.push_back(cdr_laser_scan(m.data.data(), m.data.size(), file));
    if (m.channel == joint_id) joints.push_back(cdr_joint_state(m.data.data(), m.data.size(), file));
    if (tf_ids.count(m.channel)) cdr_tf_message(m.data.data(), m.data.size(), file, tf);
  }
  if (joints.empty() && !scans.empty()) joints = joints_of_tf(tf, robot, file);
  return to_scan_log(std::move(scans), std::move(joints), robot, "rosbag2", file);
}

}  // namespace

namespace {

// The lengths a ROS 1 LaserScan or JointState declares, checked against the message's own bytes before
// rosbag deserialises it (which allocates whatever a length says: 2^30 ranges took 5 GiB in 3 s, 2^31 an
// internal error).
class Ros1Lengths {
 public:
  Ros1Lengths(const rosbag::MessageInstance& m, const std::string& file) : file_(file), buf_(m.size()) {
    ros::serialization::OStream os(buf_.data(), static_cast<uint32_t>(buf_.size()));
    m.write(os);
  }
  void laser_scan() {
    header();
    skip(7 * 4);  // angle_min, angle_max, angle_increment, time_increment, scan_time, range_min, range_max
    array(4, "ranges");
    array(4, "intensities");
  }
  void joint_state() {
    header();
    const uint32_t names = count(4, "name");
    for (uint32_t k = 0; k < names; ++k) array(1, "name");
    for (const char* what : {"position", "velocity", "effort"}) array(8, what);
  }
  void tf_message() {
    const uint32_t n = count(16 + 4 + 7 * 8, "transforms");  // header, child_frame_id, translation, rotation
    for (uint32_t k = 0; k < n; ++k) {
      header();
      array(1, "child_frame_id");
      skip(7 * 8);
    }
  }

 private:
  void header() {
    skip(12);  // seq, stamp
    array(1, "frame_id");
  }
  void skip(size_t n) {
    if (buf_.size() - at_ < n) throw input_error(file_, "a message shorter than its fields");
    at_ += n;
  }
  // An array's count, checked to fit at `least` bytes an element.
  uint32_t count(size_t least, const char* what) {
    skip(4);
    uint32_t n = 0;
    std::memcpy(&n, buf_.data() + at_ - 4, 4);
    if (n > (buf_.size() - at_) / least)
      throw input_error(file_, std::string("a message whose '") + what + "' claims " + std::to_string(n) +
                                   " elements, more than its " + std::to_string(buf_.size()) + " bytes hold");
    return n;
  }
  void array(size_t element, const char* what) { skip(count(element, what) * element); }

  std::string file_;
  std::vector<uint8_t> buf_;
  size_t at_ = 0;
};

// The top-level records of a ROS 1 bag (format 2.0: header length, header fields name=value, data length,
// data), each within the file and each with an op, stepped over as rosbag steps over them (an index record by
// its entry count, 12 bytes an entry, not by its data length): rosbag trusts the count, and a count one too
// large had crashed it; here the record after it no longer lines up.
/// One record of a ROS 1 bag: its header fields, and where its data lies.
struct Ros1Record {
  size_t start = 0, data = 0, data_len = 0;
  std::map<std::string, std::string> fields;
  int op() const {
    const auto it = fields.find("op");
    return it != fields.end() && it->second.size() == 1 ? static_cast<unsigned char>(it->second[0]) : -1;
  }
  /// A little-endian integer field of exactly sizeof(T) bytes; `what` names the record for the error.
  template <typename T>
  T number(const char* key, const std::string& path, const char* what) const {
    const auto it = fields.find(key);
    if (it == fields.end() || it->second.size() != sizeof(T))
      throw input_error(path, std::string("a bag ") + what + " record without its '" + key + "'");
    T v;
    std::memcpy(&v, it->second.data(), sizeof(T));
    return v;
  }
};

/// The `name=value` fields of a header block (each with its u32 length) in bytes [begin, end).
std::map<std::string, std::string> ros1_fields(const std::string& bytes, size_t begin, size_t end,
                                               const std::string& path) {
  std::map<std::string, std::string> fields;
  for (size_t f = begin; f < end;) {
    if (end - f < 4) throw input_error(path, "a bag record header field cut short");
    uint32_t len = 0;
    std::memcpy(&len, bytes.data() + f, 4);
    if (end - f - 4 < len) throw input_error(path, "a bag record header field past its end");
    const std::string field = bytes.substr(f + 4, len);
    const size_t eq = field.find('=');
    if (eq != std::string::npos) fields[field.substr(0, eq)] = field.substr(eq + 1);
    f += 4 + len;
  }
  return fields;
}

/// The record at `at` of `bytes` (a file, or a chunk's uncompressed records); lengths checked against it.
Ros1Record ros1_record(const std::string& bytes, size_t at, const std::string& path) {
  auto u32 = [&](size_t i) {
    uint32_t v = 0;
    std::memcpy(&v, bytes.data() + i, 4);
    return v;
  };
  Ros1Record r;
  r.start = at;
  if (bytes.size() - at < 4) throw input_error(path, "a bag record cut short");
  const size_t header_len = u32(at);
  if (bytes.size() - at - 4 < static_cast<uint64_t>(header_len) + 4)
    throw input_error(path, "a bag record header past the end");
  const size_t header = at + 4;
  r.data_len = u32(header + header_len);
  r.data = header + header_len + 4;
  if (bytes.size() - r.data < r.data_len) throw input_error(path, "a bag record's data past the end");
  r.fields = ros1_fields(bytes, header, header + header_len, path);
  if (r.op() < 0) throw input_error(path, "a bag record without an op: the records do not line up");
  return r;
}

/// A chunk's records, uncompressed (none, bz2 or lz4 as rosbag writes them), its size checked first.
std::string ros1_chunk_records(const std::string& bytes, const Ros1Record& chunk, const std::string& path) {
  constexpr uint64_t kMaxChunk = 1u << 30, kMaxRatio = 1000;  // rosbag writes 768 kB chunks
  const uint32_t size = chunk.number<uint32_t>("size", path, "chunk");
  const auto c = chunk.fields.find("compression");
  const std::string compression = c == chunk.fields.end() ? "" : c->second;
  const char* in = bytes.data() + chunk.data;
  if (compression == "none") {
    if (size != chunk.data_len) throw input_error(path, "an uncompressed bag chunk whose sizes differ");
    return std::string(in, chunk.data_len);
  }
  if (size > kMaxChunk || size > kMaxRatio * static_cast<uint64_t>(chunk.data_len) + 1024)
    throw input_error(
        path, "a bag chunk claims " + std::to_string(size) + " bytes from " + std::to_string(chunk.data_len));
  std::string out(size, '\0');
  unsigned int got = size;
  std::string packed(in, chunk.data_len);  // the decompressors take non-const input
  if (compression == "bz2") {
    if (BZ2_bzBuffToBuffDecompress(out.data(), &got, packed.data(), static_cast<unsigned>(packed.size()), 0,
                                   0) != BZ_OK ||
        got != size)
      throw input_error(path, "a bz2 bag chunk does not decompress to its size");
  } else if (compression == "lz4") {
    if (roslz4_buffToBuffDecompress(packed.data(), static_cast<unsigned>(packed.size()), out.data(), &got) !=
            ROSLZ4_OK ||
        got != size)
      throw input_error(path, "an lz4 bag chunk does not decompress to its size");
  } else {
    throw input_error(path, "a bag chunk compressed as '" + compression + "' (rosbag writes none, bz2, lz4)");
  }
  return out;
}

// rosbag follows the offsets a bag gives (the index position, chunk positions, message offsets in chunks) and
// allocates whatever length it finds there: every offset must land on a record, every length fit, before
// rosbag opens the bag.
void check_ros1_records(const std::string& path) {
  constexpr uint64_t kIndexEntryBytes = 12;
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // rosbag takes the version from the first line, whatever else is on it, and its reader of the old 1.2
  // format overruns its buffers on a malformed file: only exactly "#ROSBAG V2.0" goes on to rosbag.
  static const std::string kMagic = "#ROSBAG V2.0\n";
  if (bytes.compare(0, kMagic.size(), kMagic) != 0) {
    for (const std::string prefix : {"#ROSBAG V", "#ROSRECORD V"}) {
      if (bytes.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string line =
          bytes.substr(prefix.size(), std::min<size_t>(bytes.find('\n'), prefix.size() + 8) - prefix.size());
      const bool printable =
          std::all_of(line.begin(), line.end(), [](char c) { return (c >= '0' && c <= '9') || c == '.'; });
      throw input_error(path, "a ROS 1 bag of version " + (printable && !line.empty() ? line : "?") +
                                  " (weldtwin reads version 2.0 bags)");
    }
    throw input_error(path, "not a ROS 1 bag (no '#ROSBAG V2.0' line)");
  }
  enum : int { kBagHeader = 0x03, kIndex = 0x04, kChunk = 0x05, kChunkInfo = 0x06, kConnection = 0x07 };
  // A connection record: rosbag leaks it when a field it wants is missing (it throws past its new).
  auto check_connection = [&](const std::string& holder, const Ros1Record& c) {
    c.number<uint32_t>("conn", path, "connection");
    if (!c.fields.count("topic")) throw input_error(path, "a bag connection record without its topic");
    // Its data is a header of its own: the message type, its MD5 and definition.
    const std::map<std::string, std::string> fields = ros1_fields(holder, c.data, c.data + c.data_len, path);
    for (const char* key : {"type", "md5sum", "message_definition"})
      if (!fields.count(key))
        throw input_error(path, std::string("a bag connection record without its '") + key + "'");
  };
  std::set<uint64_t> starts, chunks;
  std::vector<uint64_t> index_pos, chunk_pos;
  std::set<uint32_t> chunk_starts;  // the records in the latest chunk, by offset in its uncompressed data
  for (size_t at = kMagic.size(); at < bytes.size();) {
    const Ros1Record r = ros1_record(bytes, at, path);
    starts.insert(at);
    switch (r.op()) {
      case kBagHeader:
        index_pos.push_back(r.number<uint64_t>("index_pos", path, "header"));
        break;
      case kChunkInfo:
        chunk_pos.push_back(r.number<uint64_t>("chunk_pos", path, "chunk info"));
        break;
      case kConnection:
        check_connection(bytes, r);
        break;
      case kChunk: {
        chunks.insert(at);
        const std::string records = ros1_chunk_records(bytes, r, path);
        chunk_starts.clear();
        for (size_t k = 0; k < records.size();) {
          const Ros1Record inner = ros1_record(records, k, path);
          if (inner.op() == kConnection) check_connection(records, inner);
          chunk_starts.insert(static_cast<uint32_t>(k));
          k = inner.data + inner.data_len;
        }
        break;
      }
      case kIndex: {
        const uint32_t n = r.number<uint32_t>("count", path, "index");
        // rosbag reads count entries whatever the record's data length says (a real bag's is wrong): the next
        // record starts after them, and must be one.
        if (static_cast<uint64_t>(n) * kIndexEntryBytes > bytes.size() - r.data)
          throw input_error(path, "an index record claims " + std::to_string(n) + " entries past the end");
        for (uint32_t k = 0; k < n; ++k) {
          uint32_t offset = 0;
          std::memcpy(&offset, bytes.data() + r.data + k * kIndexEntryBytes + 8, 4);
          if (!chunk_starts.count(offset))
            throw input_error(path, "an index entry points between the records of its chunk");
        }
        at = r.data + n * kIndexEntryBytes;
        continue;
      }
      default:
        break;
    }
    at = r.data + r.data_len;
  }
  for (const uint64_t p : index_pos)
    if (p != 0 && !starts.count(p)) throw input_error(path, "the bag's index position is not on a record");
  for (const uint64_t p : chunk_pos)
    if (!chunks.count(p)) throw input_error(path, "a chunk position of the bag's index is not on a chunk");
}

}  // namespace

ScanLog read_ros1_bag(const std::string& path, const RobotModel& robot, const BagTopics& topics) {
  if (!path_exists(path)) throw input_error(path, "no such file");
  check_ros1_records(path);
  std::vector<ScanMsg> scans;
  std::vector<JointMsg> joints;
  std::vector<TfTransform> tf;
  std::string scan_topic = topics.scan, joint_topic = topics.joints;
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Read);
    rosbag::View view(bag);
    for (const rosbag::MessageInstance& m : view) {
      const std::string& type = m.getDataType();
      if (type == "sensor_msgs/LaserScan" && (scan_topic.empty() || scan_topic == m.getTopic())) {
        scan_topic = m.getTopic();
        Ros1Lengths(m, path).laser_scan();
        const auto s = m.instantiate<sensor_msgs::LaserScan>();
        if (!s) continue;
        ScanMsg x;
        x.stamp_ns = static_cast<int64_t>(s->header.stamp.toNSec());
        x.angle_min = s->angle_min;
        x.angle_increment = s->angle_increment;
        x.time_increment = s->time_increment;
        x.range_min = s->range_min;
        x.range_max = s->range_max;
        x.ranges = s->ranges;
        x.intensities = s->intensities;
        scans.push_back(std::move(x));
      } else if (type == "sensor_msgs/JointState" && (joint_topic.empty() || joint_topic == m.getTopic())) {
        joint_topic = m.getTopic();
        Ros1Lengths(m, path).joint_state();
        const auto j = m.instantiate<sensor_msgs::JointState>();
        if (!j) continue;
        JointMsg x;
        x.stamp_ns = static_cast<int64_t>(j->header.stamp.toNSec());
        x.names = j->name;
        x.position = j->position;
        joints.push_back(std::move(x));
      } else if (type == "tf2_msgs/TFMessage") {
        Ros1Lengths(m, path).tf_message();
        const auto t = m.instantiate<tf2_msgs::TFMessage>();
        if (!t) continue;
        for (const geometry_msgs::TransformStamped& ts : t->transforms) {
          TfTransform x;
          x.stamp_ns = static_cast<int64_t>(ts.header.stamp.toNSec());
          x.parent = ts.header.frame_id;
          x.child = ts.child_frame_id;
          const auto& p = ts.transform.translation;
          const auto& q = ts.transform.rotation;
          const double v[7] = {p.x, p.y, p.z, q.x, q.y, q.z, q.w};
          tf.push_back(tf_transform(x, v, path));
        }
      }
    }
  } catch (const rosbag::BagException& e) {
    throw input_error(path, std::string("not a readable ROS 1 bag: ") + e.what());
  } catch (const ros::Exception& e) {
    throw input_error(path, std::string("a message that cannot be read: ") + e.what());
  }
  if (joints.empty() && !scans.empty()) joints = joints_of_tf(tf, robot, path);
  return to_scan_log(std::move(scans), std::move(joints), robot, "rosbag1", path);
}

void write_ros1_bag(const std::string& path, const ScanLog& log, double epoch_s, const RobotModel* tf_robot) {
  std::vector<ScanMsg> scans;
  std::vector<JointMsg> joints;
  from_scan_log(log, epoch_s, scans, joints);
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  for (const ScanMsg& m : scans) {
    sensor_msgs::LaserScan s;
    s.header.stamp = ros_time(m.stamp_ns);
    s.header.frame_id = log.lidar_frame;
    s.angle_min = m.angle_min;
    s.angle_increment = m.angle_increment;
    s.angle_max = m.angle_min + m.angle_increment * static_cast<float>(m.ranges.size() - 1);
    s.time_increment = m.time_increment;
    s.scan_time = m.time_increment * static_cast<float>(m.ranges.size());
    s.range_min = m.range_min;
    s.range_max = m.range_max;
    s.ranges = m.ranges;
    s.intensities = m.intensities;
    bag.write("/scan", s.header.stamp, s);
  }
  for (const JointMsg& m : joints) {
    if (tf_robot) {
      tf2_msgs::TFMessage msg;
      for (const TfTransform& t : tf_of(m, *tf_robot)) {
        geometry_msgs::TransformStamped ts;
        ts.header.stamp = ros_time(t.stamp_ns);
        ts.header.frame_id = t.parent;
        ts.child_frame_id = t.child;
        const Vec3 p = t.T_parent_child.translation();
        const Quat q(t.T_parent_child.rotation());
        ts.transform.translation.x = p.x(), ts.transform.translation.y = p.y(),
        ts.transform.translation.z = p.z();
        ts.transform.rotation.x = q.x(), ts.transform.rotation.y = q.y(), ts.transform.rotation.z = q.z();
        ts.transform.rotation.w = q.w();
        msg.transforms.push_back(ts);
      }
      bag.write("/tf", ros_time(m.stamp_ns), msg);
      continue;
    }
    sensor_msgs::JointState j;
    j.header.stamp = ros_time(m.stamp_ns);
    j.name = m.names;
    j.position = m.position;
    bag.write("/joint_states", j.header.stamp, j);
  }
}

ScanLog read_ros2_bag(const std::string& path, const RobotModel& robot, const BagTopics& topics) {
  if (!path_exists(path)) throw input_error(path, "no such file or directory");
  const std::string file = find_ros2_storage(path);
  if (is_mcap(file)) return read_ros2_mcap(file, robot, topics);
  Db db;
  if (sqlite3_open_v2(file.c_str(), &db.db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    throw input_error(file, "cannot be opened as sqlite3");
  // Topics of the two types.
  int scan_id = -1, joint_id = -1;
  std::set<int> tf_ids;
  {
    Stmt st;
    if (sqlite3_prepare_v2(db.db, "SELECT id, name, type, serialization_format FROM topics", -1, &st.s,
                           nullptr) != SQLITE_OK)
      throw input_error(file, "not a ROS 2 bag (no topics table)");
    int rc = SQLITE_ROW;
    while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
      const int id = sqlite3_column_int(st.s, 0);
      auto text = [&](int col) {
        const unsigned char* t = sqlite3_column_text(st.s, col);
        if (!t) throw input_error(file, "a topic without a name, type or serialization format");
        return std::string(reinterpret_cast<const char*>(t));
      };
      const std::string name = text(1), type = text(2), format = text(3);
      if (format != "cdr") continue;
      if (type == kLaserScanType && scan_id < 0 && (topics.scan.empty() || topics.scan == name)) scan_id = id;
      if (type == kJointStateType && joint_id < 0 && (topics.joints.empty() || topics.joints == name))
        joint_id = id;
      if (type == kTfType) tf_ids.insert(id);
    }
    if (rc != SQLITE_DONE)
      throw input_error(file, std::string("the topics cannot be read: ") + sqlite3_errmsg(db.db));
  }
  if (joint_id >= 0) tf_ids.clear();  // joint states, where there are any
  std::vector<TfTransform> tf;
  std::vector<ScanMsg> scans;
  std::vector<JointMsg> joints;
  Stmt st;
  if (sqlite3_prepare_v2(db.db, "SELECT topic_id, data FROM messages ORDER BY timestamp", -1, &st.s,
                         nullptr) != SQLITE_OK)
    throw input_error(file, "not a ROS 2 bag (no messages table)");
  int rc = SQLITE_ROW;
  while ((rc = sqlite3_step(st.s)) == SQLITE_ROW) {
    const int topic = sqlite3_column_int(st.s, 0);
    if (topic != scan_id && topic != joint_id && !tf_ids.count(topic)) continue;
    const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(st.s, 1));
    const auto size = static_cast<size_t>(sqlite3_column_bytes(st.s, 1));
    if (topic == scan_id)
      scans.push_back(cdr_laser_scan(data, size, file));
    else if (topic == joint_id)
      joints.push_back(cdr_joint_state(data, size, file));
    else
      cdr_tf_message(data, size, file, tf);
  }
  // A corrupt page ends the loop with an error, not with the last row: a shorter sweep must not pass as
  // whole.
  if (rc != SQLITE_DONE)
    throw input_error(file, std::string("the messages cannot all be read: ") + sqlite3_errmsg(db.db));
  if (joints.empty() && !scans.empty()) joints = joints_of_tf(tf, robot, file);
  return to_scan_log(std::move(scans), std::move(joints), robot, "rosbag2", file);
}

void write_ros2_bag(const std::string& dir, const ScanLog& log, double epoch_s, Ros2Storage storage,
                    const RobotModel* tf_robot) {
  namespace fs = std::filesystem;
  std::vector<ScanMsg> scans;
  std::vector<JointMsg> joints;
  from_scan_log(log, epoch_s, scans, joints);
  fs::create_directories(dir);
  const std::string name = fs::path(dir).filename().string();
  int64_t first = std::numeric_limits<int64_t>::max(), last = 0;
  for (const ScanMsg& m : scans) first = std::min(first, m.stamp_ns), last = std::max(last, m.stamp_ns);
  for (const JointMsg& m : joints) first = std::min(first, m.stamp_ns), last = std::max(last, m.stamp_ns);
  // The arm's topic: joint states, or the transforms of its joints.
  const std::string arm_topic = tf_robot ? "/tf" : "/joint_states";
  const std::string arm_type = tf_robot ? kTfType : kJointStateType;
  auto arm_cdr = [&](const JointMsg& m) { return tf_robot ? cdr_of(tf_of(m, *tf_robot)) : cdr_of(m); };

  if (storage == Ros2Storage::kMcap) {
    const std::string file = name + "_0.mcap";
    mcap::File bag;
    bag.profile = "ros2";
    bag.channels[1] = {1, "/scan", "cdr", kLaserScanType, "ros2msg", ""};
    bag.channels[2] = {2, arm_topic, "cdr", arm_type, "ros2msg", ""};
    // In time order, as a recorder writes them.
    for (const ScanMsg& m : scans)
      bag.messages.push_back({1, static_cast<uint64_t>(m.stamp_ns), cdr_of(m, log.lidar_frame)});
    for (const JointMsg& m : joints)
      bag.messages.push_back({2, static_cast<uint64_t>(m.stamp_ns), arm_cdr(m)});
    std::stable_sort(
        bag.messages.begin(), bag.messages.end(),
        [](const mcap::Message& a, const mcap::Message& b) { return a.log_time_ns < b.log_time_ns; });
    mcap::write((fs::path(dir) / file).string(), bag);
    write_ros2_metadata(dir, "mcap", file, scans.size(), joints.size(), first, last, arm_topic, arm_type);
    return;
  }

  const std::string db3 = name + "_0.db3";
  fs::remove(fs::path(dir) / db3);
  Db db;
  if (sqlite3_open((fs::path(dir) / db3).string().c_str(), &db.db) != SQLITE_OK)
    throw std::runtime_error(dir + ": cannot create " + db3);
  exec(db.db,
       std::string(
           "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
           "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
           "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER "
           "NOT NULL, data BLOB NOT NULL);"
           "CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
           "INSERT INTO topics VALUES (1, '/scan', '") +
           kLaserScanType + "', 'cdr', '');INSERT INTO topics VALUES (2, '" + arm_topic + "', '" + arm_type +
           "', 'cdr', '');BEGIN;");
  Stmt st;
  sqlite3_prepare_v2(db.db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1, &st.s,
                     nullptr);
  auto insert = [&](int topic, int64_t ns, const std::vector<uint8_t>& data) {
    sqlite3_bind_int(st.s, 1, topic);
    sqlite3_bind_int64(st.s, 2, ns);
    sqlite3_bind_blob(st.s, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    if (sqlite3_step(st.s) != SQLITE_DONE) throw std::runtime_error(dir + ": cannot write a message");
    sqlite3_reset(st.s);
  };
  for (const ScanMsg& m : scans) insert(1, m.stamp_ns, cdr_of(m, log.lidar_frame));
  for (const JointMsg& m : joints) insert(2, m.stamp_ns, arm_cdr(m));
  exec(db.db, "COMMIT;");
  write_ros2_metadata(dir, "sqlite3", db3, scans.size(), joints.size(), first, last, arm_topic, arm_type);
}

}  // namespace weldtwin
