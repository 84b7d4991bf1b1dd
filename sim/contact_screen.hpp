// Whether the arm touches anything at a state, answered without MuJoCo's all-pairs pass. mj_collision walks
// every pair of bodies its broad phase keeps and every pair of their geoms (about 960 geom pairs per state
// in the default cell, ~85 % of a planning question), although the arm's links are near few of them. The
// screen walks only pairs with an arm geom, and passes over a link and an obstacle at once when the sphere
// round the link's collision geoms is clear of the obstacle's bounding sphere; the pairs left go to the
// very collision functions mj_collision would call, with the same margin. It tests every pair MuJoCo
// would test for a contact the planner counts (and MuJoCo's own filters: same body, excluded or parent
// bodies, contact types), so "clear" here is "clear" for mj_collision; "touching" comes with the pair
// found touching (a contact mj_collision finds too, not always the first it would list).
#pragma once

#include <vector>

#include <mujoco/mujoco.h>

#include "sim/mujoco_world.hpp"

namespace weldtwin {

class ArmContactScreen {
 public:
  /// The pairs of `m` (the collision checker's copy: its margins and grown torch) whose contacts count: an
  /// arm geom (Label::kRobot) against any other collidable geom, arm against arm only where both are in
  /// contact (`dist <= 0`; closer than the margin is no collision among the arm's own links).
  ArmContactScreen(const mjModel* m, const std::vector<Label>& labels);

  /// A counted contact found: the arm's geom and the other geom (-1 when none was looked for).
  struct Touch {
    int arm_geom = -1, other_geom = -1;
  };

  /// After mj_kinematics on `d`: true when no pair has a counted contact; false when one has (the first
  /// found is put in `touch`), and always for a model with explicit contact pairs or overridden margins (the
  /// screen does not mirror those: ask mj_collision; `touch` is left as it was). No state of its own changes.
  bool clear(const mjModel* m, const mjData* d, Touch* touch = nullptr) const;

  /// How many geom pairs it may test, for benchmarks and tests.
  size_t pairs() const { return pair_count_; }

 private:
  struct GeomPair {
    int g1 = 0, g2 = 0;  ///< g1's type <= g2's type, as MuJoCo's table of functions wants them
    bool both_arm = false;
    bool g1_arm = false;             ///< g1 is the arm's geom (both_arm: both are)
    mjfCollision collide = nullptr;  ///< MuJoCo's function for the two types, as mj_collision calls it
  };
  // The pairs of one moving body of the arm with one other body: tested as a whole against the body's
  // bounding sphere first, then each geom of the body's (a row of pairs) with its own.
  struct BodyPair {
    int body = 0;         ///< the moving body
    int other_body = 0;   ///< another moving body (its sphere), or a static one
    int other_geom = -1;  ///< for a static body: the one geom of it this entry holds (its own sphere)
    struct Row {
      int geom = 0;               ///< a geom of `body`
      size_t first = 0, end = 0;  ///< its pairs
    };
    std::vector<GeomPair> pairs;
    std::vector<Row> rows;
  };
  struct Sphere {
    double center[3] = {0, 0, 0};  ///< body frame
    double radius = 0.0;
  };
  std::vector<BodyPair> body_pairs_;
  std::vector<int> moving_bodies_;
  std::vector<Sphere> body_sphere_;  ///< per body (moving ones filled)
  double margin_ = 0.0;              ///< the largest geom margin: every sphere test allows for it
  size_t pair_count_ = 0;
  bool screens_ = true;  ///< false: a model whose contacts the screen does not mirror
};

}  // namespace weldtwin
