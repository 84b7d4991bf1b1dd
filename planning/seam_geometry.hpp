// A seam of a part placed in the base frame, as the planner walks it: points and torch poses by arc length,
// and the poses an approach or a departure moves through.
#pragma once

#include "core/part_spec.hpp"
#include "planning/torch_frame.hpp"

namespace weldtwin {
namespace planner {

// A seam in the base frame, parameterised by arc length s in [0, length].
struct SeamGeometry {
  const Seam* seam = nullptr;
  Iso3 T_base_part = Iso3::Identity();
  double length = 0.0;
  double work = 0.0, travel = 0.0;  ///< the torch's work and travel angles [rad]

  Vec3 point(double s) const { return T_base_part * seam->point_at(s / length); }

  // The torch at s before its roll: where it points and what the roll turns.
  struct Station {
    Vec3 point;
    TorchAxes axes;
  };
  Station station(double s) const {
    const Seam::Frame f = seam->frame_at(s / length);
    const Mat3& R = T_base_part.linear();
    return {T_base_part * f.point,
            torch_axes(R * f.direction, R * seam->normal, R * f.wall_normal, work, travel)};
  }
  static Iso3 tcp(const Station& at, double roll) {
    return make_transform(at.point, torch_orientation(at.axes, roll));
  }
  Iso3 tcp(double s, double roll) const { return tcp(station(s), roll); }
};

// The pose `T` moved by `distance` along `direction` (its orientation kept).
inline Iso3 moved(const Iso3& T, const Vec3& direction, double distance) {
  Iso3 out = T;
  out.translation() += distance * direction;
  return out;
}

// The TCP pose `T_tcp` backed off by `distance` along its torch axis.
inline Iso3 backed_off(const Iso3& T_tcp, double distance) {
  Iso3 T = T_tcp;
  T.translation() -= distance * T_tcp.linear().col(2);
  return T;
}

}  // namespace planner
}  // namespace weldtwin
