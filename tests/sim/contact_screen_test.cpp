// The arm's contact screen against mj_collision itself: over random arm configurations in the cells (many
// against the table, a clamp, clutter or the arm itself, many near, many clear), with the checker's margins
// and without, the screen finds a counted contact exactly where mj_collision does — and asks MuJoCo's
// collision functions about far fewer pairs; the pair it names touching is one mj_collision counts.
#include "sim/contact_screen.hpp"

#include <gtest/gtest.h>

#include <random>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

// What the collision checker counts of mj_collision's contacts: an arm geom against another geom, arm
// against arm only when touching.
bool counts(const MujocoWorld& world, const mjContact& con) {
  const bool r1 = world.geom_label(con.geom1) == Label::kRobot,
             r2 = world.geom_label(con.geom2) == Label::kRobot;
  return (r1 || r2) && !(r1 && r2 && con.dist > 0);
}

bool counted_contact(const MujocoWorld& world, const mjData* d) {
  for (int c = 0; c < d->ncon; ++c)
    if (counts(world, d->contact[c])) return true;
  return false;
}

// Whether mj_collision counted a contact between the arm's geom `arm` and `other` (in either order).
bool counted_between(const MujocoWorld& world, const mjData* d, int arm, int other) {
  if (world.geom_label(arm) != Label::kRobot) return false;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    if (counts(world, con) &&
        ((con.geom1 == arm && con.geom2 == other) || (con.geom1 == other && con.geom2 == arm)))
      return true;
  }
  return false;
}

// Configurations the planner asks about: the shoulder and elbow mostly keep the arm over the table, the wrist
// anywhere; a quarter uniform within the limits.
JointVector planner_like_q(const RobotModel& robot, std::mt19937_64& rng, int k) {
  if (k % 4 == 0) return test::random_q(robot, rng);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  JointVector q;
  q[0] = 1.6 * u(rng);
  q[1] = 0.3 + 0.9 * u(rng);
  q[2] = 1.6 + 0.9 * u(rng);
  for (int j = 3; j < 6; ++j) q[j] = 3.0 * u(rng);
  return q;
}

void expect_same_answers(const std::string& cell_file, const std::string& robot_file, double margin_m,
                         uint64_t seed) {
  const test::Cell cell(cell_file, seed, robot_file);
  const MujocoWorld& world = *cell.world;
  // The checker's copy: the part out of MuJoCo's contacts, the arm's margin.
  ModelPtr model(mj_copyModel(nullptr, world.model()));
  mjModel* m = model.get();
  for (int g = 0; g < m->ngeom; ++g) {
    if (world.geom_label(g) == Label::kPart) m->geom_contype[g] = m->geom_conaffinity[g] = 0;
    if (world.geom_label(g) == Label::kRobot) m->geom_margin[g] = margin_m;
  }
  DataPtr d(mj_makeData(m));
  const ArmContactScreen screen(m, world.geom_labels());
  std::mt19937_64 rng(seed);
  int touching = 0, clear = 0;
  // mj_collision's answer; the screen's must be the same.
  const auto ask = [&](const JointVector& q, const std::string& what) {
    world.set_joints(m, d.get(), q);
    ArmContactScreen::Touch touch;
    const bool screened_clear = screen.clear(m, d.get(), &touch);
    mj_collision(m, d.get());
    const bool contact = counted_contact(world, d.get());
    EXPECT_EQ(screened_clear, !contact)
        << cell_file << " " << robot_file << " margin " << margin_m << " " << what << ": " << q.transpose();
    // The pair it names touches for mj_collision too, the arm's geom first.
    if (!screened_clear) {
      EXPECT_TRUE(counted_between(world, d.get(), touch.arm_geom, touch.other_geom))
          << cell_file << " " << what << ": the screen named geoms " << touch.arm_geom << " and "
          << touch.other_geom;
    }
    (contact ? touching : clear) += 1;
    return contact;
  };
  JointVector last = JointVector::Zero();
  bool last_contact = false;
  for (int k = 0; k < 3000 && !::testing::Test::HasFailure(); ++k) {
    const JointVector q = planner_like_q(cell.robot, rng, k);
    const bool contact = ask(q, "configuration " + std::to_string(k));
    // Between a touching and a clear configuration, where the contact begins (to 1e-6 of the way): the states
    // where a screen that passes over a near pair would be caught.
    if (k > 0 && contact != last_contact) {
      JointVector in = contact ? q : last, out = contact ? last : q;
      for (int i = 0; i < 20; ++i) {
        const JointVector mid = 0.5 * (in + out);
        (ask(mid, "between configurations " + std::to_string(k - 1) + " and " + std::to_string(k)) ? in
                                                                                                   : out) =
            mid;
      }
    }
    last = q, last_contact = contact;
  }
  // Both answers many times, so that neither is right by being always given.
  EXPECT_GT(touching, 1000) << cell_file;
  EXPECT_GT(clear, 1000) << cell_file;
}

TEST(ArmContactScreen, FindsAContactExactlyWhereMjCollisionDoes) {
  expect_same_answers("scenes/cells/default.yaml", "", 0.0, 1);
  expect_same_answers("scenes/cells/tube_tee.yaml", "scenes/robots/aubo_i5_cell.yaml", 0.0, 2);
  expect_same_answers("scenes/cells/round_on_plate.yaml", "scenes/robots/aubo_i5_bent22_cell.yaml", 0.0, 3);
}

TEST(ArmContactScreen, FindsAContactExactlyWhereMjCollisionDoesWithAMargin) {
  expect_same_answers("scenes/cells/default.yaml", "", 0.004, 4);
}

// An explicit contact pair is collided whatever the geoms' contact types: the screen, which mirrors only the
// types, must not call such a model clear (it leaves it to mj_collision).
TEST(ArmContactScreen, LeavesAModelWithExplicitPairsToMjCollision) {
  const char* xml = R"(<mujoco><worldbody>
    <geom name="table" type="box" size="0.4 0.4 0.02" contype="0" conaffinity="0"/>
    <body name="link" pos="0 0 0.045"><joint name="j" type="hinge" axis="0 1 0"/>
      <geom name="arm" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" contype="0" conaffinity="0"/>
    </body></worldbody>
    <contact><pair geom1="table" geom2="arm"/></contact></mujoco>)";
  ModelPtr model = load_mjcf(xml, ".", "explicit pair");
  mjModel* m = model.get();
  DataPtr d(mj_makeData(m));
  const std::vector<Label> labels = {Label::kTable, Label::kRobot};
  ASSERT_EQ(m->ngeom, 2);
  const ArmContactScreen screen(m, labels);
  d->qpos[0] = 0.0;  // the link lying 5 mm into the table
  mj_kinematics(m, d.get());
  mj_collision(m, d.get());
  ASSERT_GT(d->ncon, 0) << "the explicit pair touches";
  EXPECT_FALSE(screen.clear(m, d.get()));
}

}  // namespace
}  // namespace weldtwin
