// Small robust statistics and thinning the localizer's stages share.
#pragma once

#include <algorithm>
#include <vector>

namespace weldtwin {

constexpr double kMadToSigma = 1.4826;  ///< a Gaussian's sigma over its median absolute deviation

/// The median (the upper one of an even count); 0 for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// At most `max` elements of `v`, evenly spaced, in order.
template <typename T>
std::vector<T> thinned(const std::vector<T>& v, size_t max) {
  if (v.size() <= max) return v;
  std::vector<T> out;
  out.reserve(max);
  const double step = static_cast<double>(v.size()) / static_cast<double>(max);
  for (size_t i = 0; i < max; ++i) out.push_back(v[static_cast<size_t>(static_cast<double>(i) * step)]);
  return out;
}

}  // namespace weldtwin
