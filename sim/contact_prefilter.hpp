// An exact early-out in front of MuJoCo's general convex collider (libccd's MPR) for the pairs it handles
// with no closed form here: cylinder-cylinder, cylinder-box, and a mesh (the convex pieces of the arm's
// links) against a cylinder, a box or a mesh, i.e. the arm's links against each other, the table, the clamps
// and the clutter. Each cylinder lies inside the capsule round its axis and inside its bounding box, each
// mesh inside the box round its vertices; when those are farther apart than the pair's margin the shapes
// cannot touch, and MuJoCo's collider would find no contact either — the pair is answered "none" without
// it. Every other pair, and every pair
// that may touch, goes to MuJoCo's own function unchanged.
#pragma once

#include <mujoco/mujoco.h>

namespace weldtwin {

/// Puts the early-out in front of MuJoCo's collision functions for those pairs (process-wide, once; called
/// by install_mujoco_handlers).
void install_contact_prefilter();

/// Takes the early-out out of MuJoCo's table (false) or puts it back (true). For benchmarks: not thread-safe.
void enable_contact_prefilter(bool on);

/// The collision function for a pair of geom types (type1 <= type2) as MuJoCo calls it once the early-out is
/// installed, and MuJoCo's own function behind it. For tests.
mjfCollision prefiltered_collision_function(int type1, int type2);
mjfCollision mujoco_collision_function(int type1, int type2);

/// Distance between the capsules round two cylinder geoms (axis segments less the radii); a lower bound of
/// the cylinders' distance. For tests.
double cylinder_capsule_gap(const mjModel* m, const mjData* d, int g1, int g2);

/// Whether the bounding boxes of two geoms (cylinder, box or mesh; a cylinder's is radius x radius x
/// half-length, a mesh's the box round its vertices in the geom frame)
/// are farther apart than `margin` along some separating axis. For tests.
bool boxes_separated(const mjModel* m, const mjData* d, int g1, int g2, double margin);

}  // namespace weldtwin
