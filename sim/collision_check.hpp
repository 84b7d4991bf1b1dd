// The cell's collision test for planning: the arm at a configuration against the table, clamps, clutter and
// itself, by MuJoCo's collision detection with a safety margin. The part is left to the replay's exact-mesh
// clearance (MuJoCo would collide with its convex hull, which the torch enters at every fillet).
#pragma once

#include <memory>
#include <string>

#include "sim/mujoco_world.hpp"

namespace weldtwin {

class CollisionChecker {
 public:
  /// Robot surfaces closer than `margin_m` (MuJoCo measures the distance of convex shapes reliably only when they
  /// overlap: keep it 0 unless all geoms are boxes and spheres) to the table, a clamp or clutter count as a collision.
  explicit CollisionChecker(const MujocoWorld& world, double margin_m = 0.0);

  /// "" when the arm at q is clear, else "ROBOT_GEOM with OTHER_GEOM". Not thread-safe (one mjData); copies
  /// share it.
  std::string operator()(const JointVector& q) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace weldtwin
