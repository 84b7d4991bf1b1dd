#include "sim/lidar_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "core/error.hpp"
#include "core/geometry.hpp"

namespace weldtwin {

int LidarSetting::samples_per_turn() const {
  return static_cast<int>(std::lround(sample_rate_hz / turn_rate_hz));
}

LidarSetting LidarSetting::noise_free() const {
  LidarSetting s = *this;
  s.noise = s.quantize = s.grazing_dropouts = s.mixed_pixels = s.random_dropouts = s.stray_returns = false;
  return s;
}

void LidarSetting::apply(const std::map<std::string, double>& overrides, const std::string& source) {
  const std::map<std::string, double*> numbers = {
      {"turn_rate_hz", &turn_rate_hz},
      {"sample_rate_hz", &sample_rate_hz},
      {"min_range_m", &min_range_m},
      {"max_range_m", &max_range_m},
      {"noise_sigma_m", &noise_sigma_m},
      {"noise_sigma_rel", &noise_sigma_rel},
      {"resolution_m", &resolution_m},
      {"dropout_start_deg", &dropout_start_deg},
      {"dropout_full_deg", &dropout_full_deg},
      {"mixed_pixel_jump_m", &mixed_pixel_jump_m},
      {"mixed_pixel_probability", &mixed_pixel_probability},
      {"random_dropout_probability", &random_dropout_probability},
      {"stray_return_probability", &stray_return_probability},
  };
  const std::map<std::string, bool*> flags = {{"noise", &noise},
                                              {"quantize", &quantize},
                                              {"grazing_dropouts", &grazing_dropouts},
                                              {"mixed_pixels", &mixed_pixels},
                                              {"random_dropouts", &random_dropouts},
                                              {"stray_returns", &stray_returns}};
  for (const auto& [key, value] : overrides) {
    if (auto it = numbers.find(key); it != numbers.end()) {
      *it->second = value;
    } else if (auto f = flags.find(key); f != flags.end()) {
      *f->second = value != 0.0;
    } else if (key == "seed") {
      seed = static_cast<uint64_t>(value);
    } else {
      throw input_error(source, "unknown lidar setting '" + key + "'");
    }
  }
  // What 2D scanning LiDARs do (an RPLIDAR A2 spins at 5-15 Hz and samples at 2-8 kHz): beyond it a value
  // is a typo, and the sweep's memory grows with it (1e-9 Hz had asked for a vector beyond max_size).
  auto within = [&](const char* name, double v, double lo, double hi, const char* what) {
    if (!(v >= lo && v <= hi)) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "lidar: %s must be within %g-%g (%s), not %g", name, lo, hi, what, v);
      throw input_error(source, buf);
    }
  };
  within("turn_rate_hz", turn_rate_hz, 0.5, 50.0, "a scanner's spin");
  within("sample_rate_hz", sample_rate_hz, 100.0, 100000.0, "a scanner's sample rate");
  within("samples per turn (sample_rate_hz / turn_rate_hz)", sample_rate_hz / turn_rate_hz, 36.0, 20000.0,
         "10 deg to 0.018 deg steps");
  within("max_range_m", max_range_m, 0.1, 100.0, "a scanner's reach");
  within("min_range_m", min_range_m, 0.0, max_range_m, "below max_range_m");
  within("noise_sigma_m", noise_sigma_m, 0.0, 0.1, "range noise");
  within("noise_sigma_rel", noise_sigma_rel, 0.0, 0.1, "range noise per metre");
  within("resolution_m", resolution_m, 0.0, 0.1, "range quantisation");
  for (const auto& [name, p] :
       std::map<std::string, double>{{"mixed_pixel_probability", mixed_pixel_probability},
                                     {"random_dropout_probability", random_dropout_probability},
                                     {"stray_return_probability", stray_return_probability}})
    within(name.c_str(), p, 0.0, 1.0, "a probability");
  if (dropout_full_deg <= dropout_start_deg)
    throw input_error(source, "lidar: dropout_full_deg <= dropout_start_deg");
}

LidarErrorModel::LidarErrorModel(const LidarSetting& setting, uint64_t stream)
    : s_(setting),
      rng_(setting.seed * 0x9E3779B97F4A7C15ULL ^ (stream + 0x632BE59BD9B4E019ULL)),
      cos_start_(std::cos(deg2rad(setting.dropout_start_deg))),
      cos_full_(std::cos(deg2rad(setting.dropout_full_deg))) {}

double LidarErrorModel::measure(double range_m, double cos_incidence) {
  if (range_m > s_.max_range_m) return 0.0;
  if (s_.random_dropouts && uniform_(rng_) < s_.random_dropout_probability) return 0.0;
  if (s_.grazing_dropouts && cos_incidence < cos_start_) {
    // The chance of losing the echo grows linearly with the angle from dropout_start_deg to dropout_full_deg.
    if (cos_incidence <= cos_full_) return 0.0;
    const double deg = rad2deg(std::acos(cos_incidence));
    if (uniform_(rng_) < (deg - s_.dropout_start_deg) / (s_.dropout_full_deg - s_.dropout_start_deg))
      return 0.0;
  }
  double r = range_m;
  if (s_.stray_returns && uniform_(rng_) < s_.stray_return_probability) {
    constexpr double kBeyond = 1.2;  // multipath reports up to a fifth beyond the surface
    r = s_.min_range_m + uniform_(rng_) * (kBeyond * range_m - s_.min_range_m);
  }
  if (s_.noise) r += (s_.noise_sigma_m + s_.noise_sigma_rel * range_m) * normal_(rng_);
  if (s_.quantize) r = std::round(r / s_.resolution_m) * s_.resolution_m;
  if (r < s_.min_range_m || r > s_.max_range_m) return 0.0;
  return r;
}

uint8_t LidarErrorModel::quality(double range_m, double cos_incidence) {
  // Stronger echoes from near, head-on surfaces; the A2 reports a 6-bit quality shifted left by 2.
  const double strength = cos_incidence / (1.0 + 0.15 * range_m);
  const int q6 = std::clamp(static_cast<int>(std::lround(63.0 * strength)), 1, 63);
  return static_cast<uint8_t>(q6 << 2);
}

}  // namespace weldtwin
