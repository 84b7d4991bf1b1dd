// Embree against MuJoCo's own ray caster on the default cell: same geom, same distance.
#include "sim/embree_scene.hpp"

#include <gtest/gtest.h>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

TEST(EmbreeScene, AgreesWithMjRayOn10000RandomRays) {
  test::Cell cell;
  const MujocoWorld& w = *cell.world;
  const mjModel* m = w.model();
  std::mt19937_64 rng(99);
  // The arm somewhere in its workspace, so moving instances are exercised.
  w.set_joints(w.data(), JointVector(deg2rad(30), deg2rad(20), deg2rad(100), deg2rad(-10), deg2rad(60), 0.3));
  EmbreeScene scene(m, w.data());
  EmbreeScene::View view = scene.make_view();
  view.update(w.data());

  std::uniform_real_distribution<double> ux(-0.3, 1.0), uy(-0.8, 0.8), uz(0.02, 1.2), un(-1, 1);
  // MuJoCo casts on the groups that are drawn, as Embree does (not on collision-only pieces).
  const mjtByte drawn[mjNGROUP] = {1, 1, 1, 0, 0, 0};
  int hits = 0, same = 0, ties = 0, curved = 0;
  double worst = 0.0;
  for (int k = 0; k < 10000; ++k) {
    const Vec3 o(ux(rng), uy(rng), uz(rng));
    Vec3 d;
    do d = Vec3(un(rng), un(rng), un(rng));
    while (d.norm() < 0.1 || d.norm() > 1.0);
    d.normalize();
    int geom = -1;
    const double t_mj = mj_ray(m, w.data(), o.data(), d.data(), drawn, 1, -1, &geom);
    const RayHit hit = view.cast(o, d, 0.0, 100.0);
    ASSERT_EQ(hit.hit(), t_mj >= 0) << "ray " << k << " mj geom " << geom;
    if (!hit.hit()) continue;
    ++hits;
    const double err = std::abs(hit.distance_m - t_mj);
    worst = std::max(worst, err);
    EXPECT_LT(err, 1e-6) << "ray " << k << " geom " << geom << " vs " << hit.geom;
    if (hit.geom == geom) {
      ++same;
      const int type = m->geom_type[geom];
      curved += type == mjGEOM_CYLINDER || type == mjGEOM_CAPSULE || type == mjGEOM_SPHERE;
    } else {
      // Two surfaces at the same distance (touching geoms): either answer is right, so long as
      // MuJoCo, cast at Embree's geom alone, meets it at that same distance.
      ++ties;
      const int g = hit.geom;
      const double t_own = m->geom_type[g] == mjGEOM_MESH
                               ? mj_rayMesh(m, w.data(), g, o.data(), d.data())
                               : mju_rayGeom(w.data()->geom_xpos + 3 * g, w.data()->geom_xmat + 9 * g,
                                             m->geom_size + 3 * g, o.data(), d.data(), m->geom_type[g]);
      EXPECT_NEAR(t_own, t_mj, 1e-6) << "ray " << k << ": Embree's geom " << g
                                     << " is not at MuJoCo's distance";
    }
    // The reported normal is a unit vector facing the ray.
    EXPECT_NEAR(hit.normal.norm(), 1.0, 1e-9);
    EXPECT_LE(hit.normal.dot(d), 1e-12);
  }
  std::printf(
      "rays hitting: %d, same geom: %d, touching-surface ties: %d, on curved geoms: %d, worst |dt| %.2e m\n",
      hits, same, ties, curved, worst);
  EXPECT_GT(hits, 3000);  // a third of random directions point at something
  EXPECT_GT(curved, 20);
  EXPECT_LE(ties, hits / 100);  // ties are rare: contacts, not overlaps, in the cell
}

TEST(EmbreeScene, FollowsTheArm) {
  test::Cell cell;
  const MujocoWorld& w = *cell.world;
  EmbreeScene scene(w.model(), w.data());
  EmbreeScene::View view = scene.make_view();
  std::mt19937_64 rng(5);
  // A ray aimed at the wrist must hit the robot wherever the arm is.
  for (int k = 0; k < 50; ++k) {
    const JointVector q = test::random_q(cell.robot, rng);
    w.set_joints(w.data(), q);
    view.update(w.data());
    const int b = w.body("wrist2_Link");
    const Vec3 target(w.data()->xpos[3 * b], w.data()->xpos[3 * b + 1], w.data()->xpos[3 * b + 2]);
    if (target.z() < 0.3) continue;  // below that the part or table may stand in the way
    const Vec3 origin = target + Vec3(0.3, 0.4, 1.5);
    const RayHit hit = view.cast(origin, (target - origin).normalized(), 0.0, 10.0);
    ASSERT_TRUE(hit.hit());
    EXPECT_EQ(w.geom_label(hit.geom), Label::kRobot);
  }
}

}  // namespace
}  // namespace weldtwin
