// The cell's collision test for planning: the arm at a configuration against the table, clamps, clutter and
// itself, by MuJoCo's collision detection with a safety margin. The part is left to the replay's exact-mesh
// clearance (MuJoCo would collide with its convex hull, which the torch enters at every fillet).
#pragma once

#include <memory>
#include <string>

#include "perception/mesh_io.hpp"
#include "sim/cell_layout.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {

/// Clearance of the robot's surfaces to a part's exact mesh (Embree point queries on points 3 mm apart over
/// every robot geom, chunks far from the part skipped whole). Thread-safe; copies share the mesh.
class PartClearance {
 public:
  PartClearance(const MujocoWorld& world, const Mesh& part_mesh, const Iso3& T_base_part, double range_m);
  /// The smallest distance [m] from a robot surface to the part at the state `d` (after kinematics), negative
  /// when inside, `range_m` when nothing is nearer; `geom` names the nearest robot geom ("" if none).
  /// `hint`: where the nearest point was found last (in and out), for a sequence of nearby states — the
  /// search starts there with a tight bound. The answer is the same with or without it, to within Embree's
  /// single precision (nanometres: its queries prune in float, bounded by the best distance so far).
  struct Hint {
    int chunk = -1, point = -1;
  };
  /// A nearest point closer than this [m] is asked whether it lies inside the part (the answer then
  /// negative); one farther is taken to be outside.
  static constexpr double kInsideTestWithin_m = 0.005;
  double clearance(const mjData* d, std::string* geom = nullptr, Hint* hint = nullptr) const;
  /// The part now stands at T_base_part (the mesh stays as built; queries are moved). Copies share it.
  void set_part_pose(const Iso3& T_base_part);
  /// How many points of the arm's surface it tests (3 mm apart over every measured robot geom). They depend
  /// on the arm alone: made once per distinct arm in a process and shared by every PartClearance of it.
  size_t surface_points() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

class CollisionChecker {
 public:
  /// Robot surfaces closer than `margin_m` (MuJoCo measures the distance of convex shapes reliably only when
  /// they overlap: keep it 0 unless all geoms are boxes and spheres) to the table, a clamp or clutter count
  /// as a collision.
  /// `torch_clearance_m`: the torch's geoms are grown by this much (radius and length), so that a plan keeps
  /// the torch that far from the table, clamps and clutter — the servo-driven arm runs a little off its path
  /// (the randomized benchmark's replays found the torch 0.1-0.4 mm into a clamp arm or clutter where the
  /// plan had it just clear). Grown, not margined: MuJoCo's margin is unreliable for cylinders.
  explicit CollisionChecker(const MujocoWorld& world, double margin_m = 0.0,
                            double torch_clearance_m = 0.001);

  /// Also keep the robot `margin_m` away from the part's exact mesh at T_base_part (for planning: the pose
  /// that was found; the margins cover its error), and `weld_margin_m` while welding (the nozzle is meant to
  /// be close to the joint, but not on the part).
  void add_part(const Mesh& part_mesh, const Iso3& T_base_part, double margin_m = 0.0015,
                double weld_margin_m = 0.00075);

  /// Moves the part and its clamps to another layout of the same cell (as many clamps as the world was
  /// built with; the clutter stays): one checker answers for many placements without building the world
  /// again. Copies share it.
  void place(const CellLayout& layout);

  /// "" when the arm at q is clear, else "ROBOT_GEOM with OTHER_GEOM". Not thread-safe (one mjData); copies
  /// share it.
  std::string operator()(const JointVector& q, bool welding = false) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace weldtwin
