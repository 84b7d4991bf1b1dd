#include "planning/lspb.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {

Lspb Lspb::with_blend_fraction(double length, double speed, double f) {
  Lspb p;
  p.length = length;
  p.speed = speed;
  p.duration = length / (speed * (1.0 - f));
  p.blend = f * p.duration;
  return p;
}

Lspb Lspb::fastest(double length, double vmax, double amax) {
  Lspb p;
  p.length = length;
  if (length <= 0.0) return p;
  if (length >= vmax * vmax / amax) {
    // Trapezoid: accelerate to vmax, cruise, decelerate. L = v (T - tb), tb = v / a.
    p.speed = vmax;
    p.blend = vmax / amax;
    p.duration = length / vmax + p.blend;
  } else {
    // Triangle: L = a tb^2.
    p.blend = std::sqrt(length / amax);
    p.speed = amax * p.blend;
    p.duration = 2.0 * p.blend;
  }
  return p;
}

void Lspb::at(double t, double& s, double& sd, double& sdd) const {
  t = std::clamp(t, 0.0, duration);
  const double a = acceleration();
  if (duration <= 0.0) {
    s = length;
    sd = sdd = 0.0;
  } else if (t < blend) {
    s = 0.5 * a * t * t;
    sd = a * t;
    sdd = a;
  } else if (t <= duration - blend) {
    s = 0.5 * a * blend * blend + speed * (t - blend);
    sd = speed;
    sdd = 0.0;
  } else {
    const double r = duration - t;
    s = length - 0.5 * a * r * r;
    sd = a * r;
    sdd = -a;
  }
}

}  // namespace weldtwin
