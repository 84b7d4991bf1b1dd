#include "perception/localize/wall_patches.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {

void WallPatches::add(const Vec3& at, const Vec3& normal, double r) {
  constexpr long long kSpan = 1 << 16;  // cells per axis: 980 m, far more than a part spans
  const double turn = std::atan2(normal.y(), normal.x()) / (2.0 * M_PI) + 0.5;  // 0..1
  const long long facing = static_cast<long long>(std::floor(turn * s_.facings)) % s_.facings;
  long long key = facing;
  for (int k = 0; k < 3; ++k)
    key = key * kSpan + (static_cast<long long>(std::floor(at[k] / s_.patch_m)) + kSpan / 2) % kSpan;
  Patch& p = patches_[key];
  ++p.n;
  p.sum += r;
  p.sum2 += r * r;
  p.at += at;
}

WallPatchFigure WallPatches::figure() const {
  WallPatchFigure out;
  size_t all = 0, off = 0, worst = 0;
  for (const auto& [key, p] : patches_) {
    all += p.n;
    if (p.n < static_cast<size_t>(std::max(2, s_.min_points))) continue;
    const double n = static_cast<double>(p.n), mean = p.sum / n;
    const double var = std::max(0.0, p.sum2 / n - mean * mean) * n / (n - 1.0);
    if (std::abs(mean) <= s_.min_offset_m || std::abs(mean) <= s_.off_sigmas * std::sqrt(var / n)) continue;
    off += p.n;
    if (p.n > worst) {
      worst = p.n;
      out.worst_at = p.at / n;
      out.worst_offset_m = mean;
    }
  }
  out.off_share = all ? static_cast<double>(off) / static_cast<double>(all) : 0.0;
  return out;
}

WallPatchFigure walls_off_model(const std::vector<ResidualTerm>& fitted,
                                const std::vector<ResidualTerm>& beyond_trim, const WallPatchSetting& s) {
  WallPatches patches(s);
  // A ray's term holds its face's normal in the Jacobian's (x, y) part.
  for (const std::vector<ResidualTerm>* terms : {&fitted, &beyond_trim})
    for (const ResidualTerm& t : *terms) patches.add(t.at, Vec3(t.J.y(), t.J.z(), 0.0), t.r);
  return patches.figure();
}

}  // namespace weldtwin
