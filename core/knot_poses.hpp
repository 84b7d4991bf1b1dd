// A moving sensor's pose at each of its samples, computed exactly only at every `step`-th sample (a knot) and
// interpolated linearly between two knots close in time: over a few milliseconds an arm's motion is a
// straight line to far under a micrometre, and the exact pose (joint interpolation, forward kinematics) costs
// far more than the interpolation. The one knot interpolator of the twin's sweep and of scan assembly.
#pragma once

#include <cstddef>
#include <limits>
#include <utility>

#include "core/geometry.hpp"

namespace weldtwin {

/// `exact(i, T)`: the exact pose of sample i into T, false when there is none (outside the joint log);
/// `time(i)`: sample i's time, increasing with i (any unit, as long as `max_gap` is in it).
template <typename Exact, typename Time>
class KnotPoses {
 public:
  KnotPoses(size_t samples, size_t step, double max_gap, Exact exact, Time time)
      : samples_(samples), step_(step), max_gap_(max_gap), exact_(std::move(exact)), time_(std::move(time)) {}

  /// The pose of sample i: interpolated between the knots around it when both have a pose and lie at most
  /// max_gap apart, else exact; false when it has none. Cheapest for samples asked in increasing order (each
  /// knot computed once, the end of one interval reused as the start of the next).
  bool pose(size_t i, Iso3& T) {
    if (step_ > 1 && i / step_ * step_ != knot_a_) {
      const size_t a = i / step_ * step_, b = a + step_;  // past the last knot: every sample exactly
      const bool reuse = knots_ && a == knot_a_ + step_;
      if (reuse) Ta_ = Tb_;
      knot_a_ = a;
      ta_ = time_(a);
      tb_ = b < samples_ ? time_(b) : ta_;
      knots_ = tb_ > ta_ && tb_ - ta_ <= max_gap_ && (reuse || exact_(a, Ta_)) && exact_(b, Tb_);
    }
    const double t = time_(i);
    if (knots_ && t >= ta_ && t <= tb_) {
      T = lerp_pose(Ta_, Tb_, (t - ta_) / (tb_ - ta_));  // u = 0 gives Ta exactly
      return true;
    }
    return exact_(i, T);
  }

 private:
  size_t samples_, step_;
  double max_gap_;
  Exact exact_;
  Time time_;
  size_t knot_a_ = std::numeric_limits<size_t>::max();
  bool knots_ = false;
  Iso3 Ta_ = Iso3::Identity(), Tb_ = Iso3::Identity();
  double ta_ = 0.0, tb_ = 0.0;
};

}  // namespace weldtwin
