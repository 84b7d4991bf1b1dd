// The early-out in front of MuJoCo's convex collider: over random poses of cylinders, a box and meshes (many
// touching, many near, many apart) it answers exactly what MuJoCo's own function answers, and it answers most
// of the pairs that are apart on its own.
#include "sim/contact_prefilter.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "sim/mujoco_world.hpp"

namespace weldtwin {
namespace {

// Two convex meshes as the arm's link pieces are: uneven, their vertices' centre off their origin.
const char* kShapes = R"(<mujoco><asset>
  <mesh name="wedge" vertex="0 0 0  0.12 0 0  0 0.05 0  0.12 0.03 0  0 0 0.09  0.12 0 0.02  0 0.05 0.08  0.1 0.04 0.03"/>
  <mesh name="slab" vertex="-0.03 -0.06 -0.01  0.04 -0.06 -0.01  -0.03 0.06 -0.01  0.04 0.07 -0.01  -0.02 -0.05 0.03  0.03 -0.05 0.03  -0.02 0.05 0.03  0.03 0.05 0.04"/>
</asset><worldbody>
  <body name="a"><freejoint/><geom name="a" type="cylinder" size="0.04 0.1"/></body>
  <body name="b"><freejoint/><geom name="b" type="cylinder" size="0.015 0.12"/></body>
  <body name="c"><freejoint/><geom name="c" type="box" size="0.05 0.012 0.07"/></body>
  <body name="d"><freejoint/><geom name="d" type="mesh" mesh="wedge"/></body>
  <body name="e"><freejoint/><geom name="e" type="mesh" mesh="slab"/></body>
</worldbody></mujoco>)";

// Free bodies posed at random within a cube of side `spread` [m], turned at random.
void random_poses(const mjModel* m, mjData* d, std::mt19937_64& rng, double spread) {
  std::uniform_real_distribution<double> u(-0.5 * spread, 0.5 * spread);
  std::normal_distribution<double> n;
  for (int b = 0; b < m->njnt; ++b) {
    mjtNum* q = d->qpos + m->jnt_qposadr[b];
    for (int i = 0; i < 3; ++i) q[i] = u(rng);
    mjtNum quat[4] = {n(rng), n(rng), n(rng), n(rng)};
    mju_normalize4(quat);
    std::memcpy(q + 3, quat, sizeof quat);
  }
  mj_kinematics(m, d);
}

struct Tally {
  int pairs = 0, touching = 0, pruned = 0;
};

// Both functions on one pair; the contacts must agree field for field.
void compare(const mjModel* m, const mjData* d, int g1, int g2, double margin, Tally& tally) {
  const int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
  mjContact ours[mjMAXCONPAIR], theirs[mjMAXCONPAIR];
  std::memset(ours, 0, sizeof ours);
  std::memset(theirs, 0, sizeof theirs);
  const int n_ours = prefiltered_collision_function(t1, t2)(m, d, ours, g1, g2, margin);
  const int n_theirs = mujoco_collision_function(t1, t2)(m, d, theirs, g1, g2, margin);
  ASSERT_EQ(n_ours, n_theirs) << "geoms " << g1 << ", " << g2 << " margin " << margin;
  for (int k = 0; k < n_ours; ++k) {
    EXPECT_EQ(ours[k].dist, theirs[k].dist);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(ours[k].pos[i], theirs[k].pos[i]);
  }
  ++tally.pairs;
  tally.touching += n_theirs > 0;
  const bool apart = (t1 == mjGEOM_CYLINDER && t2 == mjGEOM_CYLINDER &&
                      cylinder_capsule_gap(m, d, g1, g2) > margin + 1e-6) ||
                     boxes_separated(m, d, g1, g2, margin);
  tally.pruned += apart;
  if (apart) {
    EXPECT_EQ(n_theirs, 0) << "an early-out on a pair MuJoCo finds in contact";
  }
}

TEST(ContactPrefilter, AnswersAsMujocosColliderAndSkipsMostPairsThatAreApart) {
  install_mujoco_handlers();
  const ModelPtr model = load_mjcf(kShapes, ".", "contact_prefilter_test");
  const mjModel* m = model.get();
  DataPtr data(mj_makeData(m));
  std::mt19937_64 rng(7);
  Tally cyl_cyl, cyl_box, mesh_any;
  for (int k = 0; k < 6000; ++k) {
    // Crowded cubes give touching pairs, wide ones pairs apart; margins of none to 2 cm.
    random_poses(m, data.get(), rng, k % 3 == 0 ? 0.15 : k % 3 == 1 ? 0.3 : 0.6);
    const double margin = (k % 4) * 0.005;
    compare(m, data.get(), 0, 1, margin, cyl_cyl);
    compare(m, data.get(), 0, 2, margin, cyl_box);
    compare(m, data.get(), 1, 2, margin, cyl_box);
    compare(m, data.get(), 0, 3, margin, mesh_any);  // cylinder-mesh
    compare(m, data.get(), 2, 4, margin, mesh_any);  // box-mesh
    compare(m, data.get(), 3, 4, margin, mesh_any);  // mesh-mesh
    if (HasFatalFailure()) return;
  }
  std::printf("cylinder-cylinder: %d pairs, %d touching, %d answered early\n", cyl_cyl.pairs,
              cyl_cyl.touching, cyl_cyl.pruned);
  std::printf("cylinder-box: %d pairs, %d touching, %d answered early\n", cyl_box.pairs, cyl_box.touching,
              cyl_box.pruned);
  std::printf("mesh with cylinder, box, mesh: %d pairs, %d touching, %d answered early\n", mesh_any.pairs,
              mesh_any.touching, mesh_any.pruned);
  // The poses cover both cases, and the early-out takes most pairs that do not touch.
  for (const Tally* t : {&cyl_cyl, &cyl_box, &mesh_any}) {
    EXPECT_GT(t->touching, t->pairs / 10);
    EXPECT_GT(t->pruned, (t->pairs - t->touching) / 2);
  }
}

TEST(ContactPrefilter, CapsuleGapIsTheSegmentsDistanceLessTheRadii) {
  install_mujoco_handlers();
  const ModelPtr model = load_mjcf(kShapes, ".", "contact_prefilter_test");
  const mjModel* m = model.get();
  DataPtr data(mj_makeData(m));
  mjData* d = data.get();
  std::mt19937_64 rng(11);
  auto point = [&](int g, double s, double out[3]) {  // s in [-1, 1] along the axis
    for (int r = 0; r < 3; ++r)
      out[r] = d->geom_xpos[3 * g + r] + s * m->geom_size[3 * g + 1] * d->geom_xmat[9 * g + 3 * r + 2];
  };
  for (int k = 0; k < 200; ++k) {
    random_poses(m, d, rng, 0.4);
    // The distance of the axes by brute force over 401 x 401 points of each.
    double best = 1e9;
    for (int i = 0; i <= 400; ++i)
      for (int j = 0; j <= 400; ++j) {
        double p[3], q[3];
        point(0, -1.0 + i / 200.0, p);
        point(1, -1.0 + j / 200.0, q);
        best = std::min(best, std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                                        (p[2] - q[2]) * (p[2] - q[2])));
      }
    const double gap = cylinder_capsule_gap(m, d, 0, 1) + m->geom_size[0] + m->geom_size[3];
    EXPECT_LE(gap, best + 1e-12);   // never more than a point pair's distance
    EXPECT_GT(gap, best - 0.6e-3);  // and within the sampling step (0.5 mm along b's axis)
  }
}

}  // namespace
}  // namespace weldtwin
