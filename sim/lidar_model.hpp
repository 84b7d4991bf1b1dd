// The RPLIDAR A2 (A2M8) model: timing, range limits and every error effect, each switchable, with the
// defaults of docs/design.md. The sweep simulator applies it to exact ray hits.
#pragma once

#include <cstdint>
#include <map>
#include <random>
#include <string>

namespace weldtwin {

struct LidarSetting {
  double turn_rate_hz = 10.0;      ///< turns per second
  double sample_rate_hz = 8000.0;  ///< samples per second (800 per turn: 0.45 deg)
  double min_range_m = 0.15;       ///< closer returns are reported as no return
  double max_range_m = 12.0;       ///< farther surfaces give no return

  bool noise = true;                ///< Gaussian range noise
  double noise_sigma_m = 0.0015;    ///< constant part of the range sigma [m]
  double noise_sigma_rel = 0.0025;  ///< part proportional to the range [m per m]

  bool quantize = true;           ///< round ranges to the reported resolution
  double resolution_m = 0.00025;  ///< distance resolution (q2 millimetres) [m]

  bool grazing_dropouts = true;     ///< returns vanish at grazing incidence
  double dropout_start_deg = 70.0;  ///< incidence angle where dropouts start
  double dropout_full_deg = 85.0;   ///< incidence angle beyond which nothing returns

  bool mixed_pixels = true;              ///< at depth edges the beam straddles both surfaces
  double mixed_pixel_jump_m = 0.03;      ///< minimum range jump between neighbours that counts as an edge
  double mixed_pixel_probability = 0.5;  ///< chance that a sample at an edge reports a blend

  bool random_dropouts = true;  ///< occasional lost samples anywhere
  double random_dropout_probability = 0.002;

  /// Stray returns (off by default: the benchmark draws them when asked): a sample reports a range anywhere
  /// between the minimum range and a fifth beyond its surface, as spatter, dust or multipath off bright
  /// steel give; points in the volume in front of the surface, and behind it.
  bool stray_returns = false;
  double stray_return_probability = 0.002;

  uint64_t seed = 1;  ///< noise seed (the sweep mixes in the turn index)

  int samples_per_turn() const;
  /// All error effects off: exact ranges (still limited to [min_range, max_range]).
  LidarSetting noise_free() const;
  /// Applies `name: value` overrides (booleans as 0/1); throws InputError naming `source` for unknown names.
  void apply(const std::map<std::string, double>& overrides, const std::string& source);
};

/// Applies range noise and quantisation to an exact range, and decides dropouts. Returns 0 for no return.
class LidarErrorModel {
 public:
  LidarErrorModel(const LidarSetting& setting, uint64_t stream);
  /// The reported range for an exact hit at `range_m`, the beam meeting the surface at an incidence angle
  /// whose cosine is `cos_incidence` (1 = head-on).
  double measure(double range_m, double cos_incidence);
  /// Quality byte for a return (0..255), decreasing with range and incidence.
  static uint8_t quality(double range_m, double cos_incidence);
  double uniform() { return uniform_(rng_); }

 private:
  const LidarSetting& s_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  double cos_start_, cos_full_;  ///< cosines of the dropout angles
};

}  // namespace weldtwin
