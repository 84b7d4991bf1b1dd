#include "core/scan_log.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <random>

#include "core/error.hpp"

namespace weldtwin {
namespace {

ScanLog random_log(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  ScanLog log;
  log.joint_names = {"a", "b", "c", "d", "e", "f"};
  for (uint32_t t = 0; t < 5; ++t) {
    log.turns.push_back({t * 0.1, t * 7, 7});
    for (int k = 0; k < 7; ++k)
      log.samples.push_back({t * 0.1 + k * 1e-3, static_cast<float>(u(rng) * 6.28),
                             k == 3 ? 0.0f : static_cast<float>(u(rng) * 5),
                             static_cast<uint8_t>(k == 3 ? 0 : 200)});
  }
  for (int k = 0; k < 11; ++k) log.joints.push_back({k * 0.05, JointVector::Random()});
  return log;
}

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / name).string();
}

TEST(ScanLog, RoundTripIsExact) {
  const ScanLog a = random_log(3);
  a.write(temp("wt_roundtrip.scanlog"));
  const ScanLog b = ScanLog::read(temp("wt_roundtrip.scanlog"));
  ASSERT_EQ(b.samples.size(), a.samples.size());
  ASSERT_EQ(b.turns.size(), a.turns.size());
  ASSERT_EQ(b.joints.size(), a.joints.size());
  EXPECT_EQ(b.joint_names, a.joint_names);
  for (size_t i = 0; i < a.samples.size(); ++i) {
    EXPECT_EQ(b.samples[i].t_s, a.samples[i].t_s);
    EXPECT_EQ(b.samples[i].angle_rad, a.samples[i].angle_rad);
    EXPECT_EQ(b.samples[i].range_m, a.samples[i].range_m);
    EXPECT_EQ(b.samples[i].quality, a.samples[i].quality);
  }
  for (size_t i = 0; i < a.joints.size(); ++i) EXPECT_EQ(b.joints[i].q, a.joints[i].q);
  EXPECT_EQ(b.turns[2].first, 14u);
  EXPECT_EQ(b.valid_samples(), a.samples.size() - 5);
}

TEST(ScanLog, MalformedFilesAreInputErrors) {
  const std::string path = temp("wt_bad.scanlog");
  random_log(4).write(path);
  const auto full = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, full - 9);
  EXPECT_THROW(ScanLog::read(path), InputError);  // truncated
  std::ofstream(temp("wt_empty.scanlog")).close();
  EXPECT_THROW(ScanLog::read(temp("wt_empty.scanlog")), InputError);
  std::ofstream(temp("wt_magic.scanlog")) << "PCD v0.7\n{}\n";
  EXPECT_THROW(ScanLog::read(temp("wt_magic.scanlog")), InputError);
  std::ofstream(temp("wt_header.scanlog")) << "WELDTWIN-SCANLOG 1\n{\"robot\": 3\n";
  EXPECT_THROW(ScanLog::read(temp("wt_header.scanlog")), InputError);
  EXPECT_THROW(ScanLog::read(temp("wt_missing.scanlog")), InputError);
}

// A count written as a float (8.6e20, as the fuzzer wrote it) had been converted to size_t: undefined
// behaviour. A valid log written to `path` with one header field changed.
void write_with_header(const std::string& path, const std::function<void(nlohmann::json&)>& change) {
  random_log(4).write(path);
  std::ifstream in(path, std::ios::binary);
  std::string magic, header;
  std::getline(in, magic);
  std::getline(in, header);
  const std::string body((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  nlohmann::json h = nlohmann::json::parse(header);
  change(h);
  std::ofstream(path, std::ios::binary) << magic << "\n" << h.dump() << "\n" << body;
}

TEST(ScanLog, CountsMustBeWholeNumbers) {
  const std::string path = temp("wt_float.scanlog");
  for (const nlohmann::json& bad : {nlohmann::json(8.6e20), nlohmann::json(-3), nlohmann::json("4")}) {
    write_with_header(path, [&](nlohmann::json& h) { h["num_samples"] = bad; });
    try {
      ScanLog::read(path);
      ADD_FAILURE() << bad.dump() << " was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("'num_samples' must be a whole number"), std::string::npos)
          << e.what();
    }
  }
}

// A count that wraps the size check (num_turns + 2^60: times 16 bytes, the same sum modulo 2^64) had passed
// it and then asked for 2^60 turns (an internal error); now refused as the header promising too much.
TEST(ScanLog, CountsThatWrapTheSizeCheckAreRefused) {
  const std::string path = temp("wt_wrap.scanlog");
  write_with_header(
      path, [](nlohmann::json& h) { h["num_turns"] = h["num_turns"].get<uint64_t>() + (uint64_t{1} << 60); });
  try {
    ScanLog::read(path);
    FAIL() << "read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("promises more records"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace weldtwin
