// Linear segment with parabolic blends (docs/design.md): a distance L at speed v with blends of tb = f T at
// both ends; T = L / (v (1 - f)), blend acceleration v / tb. Also the fastest LSPB for velocity and
// acceleration limits, used for joint-space moves.
#pragma once

namespace weldtwin {

struct Lspb {
  double length = 0.0;  ///< distance covered (any unit)
  double speed = 0.0;   ///< cruise speed
  double blend = 0.0;   ///< blend time tb [s]
  double duration = 0.0;

  /// The paper's law: cruise at `speed`, blends a fraction `f` of the total time.
  static Lspb with_blend_fraction(double length, double speed, double f);
  /// The shortest LSPB for |velocity| <= vmax and |acceleration| <= amax (a triangle when too short to
  /// cruise).
  static Lspb fastest(double length, double vmax, double amax);

  double acceleration() const { return blend > 0 ? speed / blend : 0.0; }
  /// Distance, speed and acceleration at time t (clamped to [0, duration]).
  void at(double t, double& s, double& sd, double& sdd) const;
};

}  // namespace weldtwin
