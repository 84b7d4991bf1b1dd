#include "sim/collision_check.hpp"

namespace weldtwin {

struct CollisionChecker::State {
  const MujocoWorld* world = nullptr;
  ModelPtr model;
  DataPtr data;
};

CollisionChecker::CollisionChecker(const MujocoWorld& world, double margin_m) : state_(std::make_shared<State>()) {
  install_mujoco_handlers();
  state_->world = &world;
  state_->model.reset(mj_copyModel(nullptr, world.model()));
  mjModel* m = state_->model.get();
  for (int g = 0; g < m->ngeom; ++g) {
    if (world.geom_label(g) == Label::kPart) m->geom_contype[g] = m->geom_conaffinity[g] = 0;
    if (world.geom_label(g) == Label::kRobot) m->geom_margin[g] = margin_m;
  }
  state_->data.reset(mj_makeData(m));
}

std::string CollisionChecker::operator()(const JointVector& q) const {
  const mjModel* m = state_->model.get();
  mjData* d = state_->data.get();
  const MujocoWorld& world = *state_->world;
  for (size_t i = 0; i < world.qpos_adr().size(); ++i) d->qpos[world.qpos_adr()[i]] = q[static_cast<int>(i)];
  mj_kinematics(m, d);
  mj_collision(m, d);
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    const bool r1 = world.geom_label(con.geom1) == Label::kRobot, r2 = world.geom_label(con.geom2) == Label::kRobot;
    if (!r1 && !r2) continue;
    if (r1 && r2 && con.dist > 0) continue;  // the margin is for the cell; the arm's own links may be close
    const int robot = r1 ? con.geom1 : con.geom2, other = r1 ? con.geom2 : con.geom1;
    const char* a = mj_id2name(m, mjOBJ_GEOM, robot);
    const char* b = mj_id2name(m, mjOBJ_GEOM, other);
    return std::string(a ? a : "robot") + " with " + (b ? b : "geom " + std::to_string(other));
  }
  return "";
}

}  // namespace weldtwin
