// The MuJoCo cell mirrors the URDF: forward kinematics agree, and geoms are labelled by what they belong to.
#include "sim/mujoco_world.hpp"

#include <gtest/gtest.h>

#include <set>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

Iso3 body_pose(const mjData* d, int b) {
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = d->xmat[9 * b + 3 * r + c];
  return make_transform(Vec3(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]), R);
}

TEST(MujocoWorld, UrdfKinematicsEqualMujocoBodyPosesFor1000Configurations) {
  test::Cell cell;
  const MujocoWorld& w = *cell.world;
  std::mt19937_64 rng(2024);
  std::vector<Iso3> fk;
  double worst_p = 0.0, worst_r = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const JointVector q = test::random_q(cell.robot, rng);
    w.set_joints(w.data(), q);
    cell.robot.forward_kinematics(q, fk);
    for (size_t l = 0; l < fk.size(); ++l) {
      const Iso3 T_mj = body_pose(w.data(), w.body(cell.robot.links()[l].name));
      worst_p = std::max(worst_p, (T_mj.translation() - fk[l].translation()).norm());
      worst_r = std::max(worst_r, (T_mj.linear() - fk[l].linear()).cwiseAbs().maxCoeff());
    }
  }
  std::printf("URDF vs MuJoCo over 1000 configurations: worst position %.1e m, rotation entry %.1e\n",
              worst_p, worst_r);
  EXPECT_LT(worst_p, 1e-9);
  EXPECT_LT(worst_r, 1e-9);
}

TEST(MujocoWorld, TheArmsCachedChainPosesItsBodiesAsMjKinematics) {
  // The sweep poses the LiDAR and the arm's bodies through the world's robot model with a chain cache;
  // whatever joints change between calls (the base alone, a wrist alone, all), it must agree with MuJoCo.
  test::Cell cell;
  const MujocoWorld& w = *cell.world;
  const RobotModel& arm = w.robot();
  for (const char* link : {"lidar", "tcp", "shoulder_Link"}) {
    const int body = w.body(link);
    ASSERT_EQ(w.robot_link(body), arm.require_link(link));
    RobotModel::ChainCache cache;
    std::mt19937_64 rng(11);
    JointVector q = test::random_q(cell.robot, rng);
    for (int k = 0; k < 300; ++k) {
      const JointVector r = test::random_q(cell.robot, rng);
      const int changed = k % 3;  // 0: J1 only, 1: J5 only, 2: all
      if (changed == 0) q[0] = r[0];
      if (changed == 1) q[4] = r[4];
      if (changed == 2) q = r;
      w.set_joints(w.data(), q);
      const Iso3 a = arm.forward_kinematics(q, w.robot_link(body), cache), b = body_pose(w.data(), body);
      EXPECT_LT((a.translation() - b.translation()).norm(), 1e-12) << link << " step " << k;
      EXPECT_LT((a.linear() - b.linear()).cwiseAbs().maxCoeff(), 1e-12) << link << " step " << k;
    }
  }
  EXPECT_EQ(w.robot_link(w.body("part")), -1);
}

TEST(MujocoWorld, GeomsAreLabelledByOwner) {
  test::Cell cell;
  const mjModel* m = cell.world->model();
  auto label_of = [&](const char* geom) { return cell.world->geom_label(mj_name2id(m, mjOBJ_GEOM, geom)); };
  EXPECT_EQ(label_of("part"), Label::kPart);
  EXPECT_EQ(label_of("table_top"), Label::kTable);
  EXPECT_EQ(label_of("table_leg_1"), Label::kTable);
  EXPECT_EQ(label_of("clamp0_pad"), Label::kClamp);
  EXPECT_EQ(label_of("clamp1_handle"), Label::kClamp);
  EXPECT_EQ(label_of("wrist2_Link_mesh0"), Label::kRobot);
  EXPECT_EQ(label_of("wrist2_Link_mesh0_hull0"), Label::kRobot);
  EXPECT_EQ(label_of("wrist2_Link_visual0"), Label::kRobot);
  // The vendor's meshes: the visual one seen (drawn, ray-cast), the collision one measured for the part's
  // clearance only, its convex pieces collided only; only the pieces and primitives collide.
  auto id = [&](const char* geom) { return mj_name2id(m, mjOBJ_GEOM, geom); };
  EXPECT_TRUE(seen(m, id("wrist2_Link_visual0")));
  EXPECT_FALSE(measured_for_clearance(m, id("wrist2_Link_visual0")));
  EXPECT_FALSE(seen(m, id("wrist2_Link_mesh0")));
  EXPECT_TRUE(measured_for_clearance(m, id("wrist2_Link_mesh0")));
  EXPECT_FALSE(seen(m, id("wrist2_Link_mesh0_hull0")));
  EXPECT_FALSE(measured_for_clearance(m, id("wrist2_Link_mesh0_hull0")));
  for (const char* g : {"wrist2_Link_visual0", "wrist2_Link_mesh0"})
    EXPECT_EQ(m->geom_contype[id(g)], 0) << g;
  EXPECT_NE(m->geom_contype[id("wrist2_Link_mesh0_hull0")], 0);
  EXPECT_EQ(label_of("torch_0"), Label::kRobot);
  EXPECT_EQ(label_of("lidar_0"), Label::kRobot);
  EXPECT_EQ(label_of("floor"), Label::kOther);
  EXPECT_EQ(label_of("clutter0_box"), Label::kOther);
  // Every geom got a label, and all five kinds occur.
  std::set<Label> seen(cell.world->geom_labels().begin(), cell.world->geom_labels().end());
  EXPECT_EQ(seen.size(), 5u);
}

}  // namespace
}  // namespace weldtwin
