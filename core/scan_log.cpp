#include "core/scan_log.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.hpp"

namespace weldtwin {
namespace {

constexpr const char* kMagic = "WELDTWIN-SCANLOG 1";
constexpr size_t kTurnBytes = 16;    // f64 t_start, u32 first, u32 count
constexpr size_t kSampleBytes = 17;  // f64 t, f32 angle, f32 range, u8 quality
constexpr size_t kJointBytes = 56;   // f64 t, 6 x f64 q

template <typename T>
void put(std::string& buf, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  buf.append(b, sizeof(T));
}

template <typename T>
T get(const char*& p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  p += sizeof(T);
  return v;
}

}  // namespace

size_t ScanLog::valid_samples() const {
  size_t n = 0;
  for (const auto& s : samples) n += s.range_m > 0.0f;
  return n;
}

void ScanLog::write(const std::string& path) const {
  nlohmann::json header = {
      {"source", source},
      {"robot", robot},
      {"lidar_frame", lidar_frame},
      {"lidar_model", lidar_model},
      {"joint_names", joint_names},
      {"num_turns", turns.size()},
      {"num_samples", samples.size()},
      {"num_joint_states", joints.size()},
      {"byte_order", "little"},
      {"turn_record", "f64 t_start_s, u32 first_sample, u32 sample_count"},
      {"sample_record", "f64 t_s, f32 angle_rad (ccw about +z), f32 range_m (0 = no return), u8 quality"},
      {"joint_record", "f64 t_s, f64 q_rad[6]"},
  };
  std::string body;
  body.reserve(turns.size() * kTurnBytes + samples.size() * kSampleBytes + joints.size() * kJointBytes);
  for (const auto& t : turns) {
    put(body, t.t_start_s);
    put(body, t.first);
    put(body, t.count);
  }
  for (const auto& s : samples) {
    put(body, s.t_s);
    put(body, s.angle_rad);
    put(body, s.range_m);
    put(body, s.quality);
  }
  for (const auto& j : joints) {
    put(body, j.t_s);
    for (int k = 0; k < 6; ++k) put(body, j.q[k]);
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << kMagic << '\n' << header.dump() << '\n';
  out.write(body.data(), static_cast<std::streamsize>(body.size()));
  if (!out) throw std::runtime_error(path + ": write failed");
}

ScanLog ScanLog::read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path, "cannot open the scan log");
  std::string magic, header_line;
  if (!std::getline(in, magic)) throw input_error(path, "empty file, not a scan log");
  if (magic != kMagic)
    throw input_error(path, "not a weldtwin scan log (first line is not '" + std::string(kMagic) + "')");
  if (!std::getline(in, header_line)) throw input_error(path, "scan log header missing");
  nlohmann::json h;
  try {
    h = nlohmann::json::parse(header_line);
  } catch (const nlohmann::json::exception& e) {
    throw input_error(path, std::string("malformed scan log header: ") + e.what());
  }
  ScanLog log;
  size_t nt = 0, ns = 0, nj = 0;
  try {
    log.source = h.value("source", "unknown");
    log.robot = h.at("robot").get<std::string>();
    log.lidar_frame = h.at("lidar_frame").get<std::string>();
    log.lidar_model = h.value("lidar_model", "");
    log.joint_names = h.at("joint_names").get<std::vector<std::string>>();
    // Counts must be whole numbers as JSON has them: a float (8.6e20) would not convert to size_t.
    auto count = [&](const char* key) {
      const auto& v = h.at(key);
      if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<long long>() >= 0))
        throw input_error(path, std::string("scan log header: '") + key + "' must be a whole number");
      return v.get<size_t>();
    };
    nt = count("num_turns");
    ns = count("num_samples");
    nj = count("num_joint_states");
    if (h.value("byte_order", "little") != "little")
      throw input_error(path, "only little-endian logs are supported");
  } catch (const nlohmann::json::exception& e) {
    throw input_error(path, std::string("scan log header: ") + e.what());
  }
  if (log.joint_names.size() != 6) throw input_error(path, "scan log must name 6 joints");

  const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Each count bounded by the body before the sum is taken: counts near 2^64 / bytes wrap the sum round to
  // the body's size.
  if (nt > body.size() / kTurnBytes || ns > body.size() / kSampleBytes || nj > body.size() / kJointBytes)
    throw input_error(path, "truncated scan log: the header promises more records than the body holds");
  const size_t expected = nt * kTurnBytes + ns * kSampleBytes + nj * kJointBytes;
  if (body.size() != expected)
    throw input_error(path, "truncated or padded scan log: body has " + std::to_string(body.size()) +
                                " bytes, header promises " + std::to_string(expected));
  const char* p = body.data();
  log.turns.resize(nt);
  for (auto& t : log.turns) {
    t.t_start_s = get<double>(p);
    t.first = get<uint32_t>(p);
    t.count = get<uint32_t>(p);
    if (static_cast<size_t>(t.first) + t.count > ns)
      throw input_error(path, "a turn points past the last sample");
  }
  log.samples.resize(ns);
  for (auto& s : log.samples) {
    s.t_s = get<double>(p);
    s.angle_rad = get<float>(p);
    s.range_m = get<float>(p);
    s.quality = get<uint8_t>(p);
    if (!std::isfinite(s.t_s) || !std::isfinite(s.angle_rad) || !std::isfinite(s.range_m) || s.range_m < 0.0f)
      throw input_error(path, "sample with a non-finite time, angle or range, or a negative range");
  }
  log.joints.resize(nj);
  for (size_t i = 0; i < nj; ++i) {
    JointState& j = log.joints[i];
    j.t_s = get<double>(p);
    for (int k = 0; k < 6; ++k) j.q[k] = get<double>(p);
    if (!std::isfinite(j.t_s) || !j.q.allFinite())
      throw input_error(path, "joint state with a non-finite value");
    if (i > 0 && j.t_s <= log.joints[i - 1].t_s)
      throw input_error(path, "joint states are not increasing in time");
  }
  return log;
}

}  // namespace weldtwin
