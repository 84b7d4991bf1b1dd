// The cell as a MuJoCo world: the MJCF composed from the cell (environment + robot + part + clamps +
// clutter), loaded into an mjModel, with every geom labelled by what it belongs to.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "core/robot_model.hpp"
#include "sim/cell_layout.hpp"

namespace weldtwin {

/// What a LiDAR point hit. Stored per point in a synthetic scan's truth.
enum class Label : uint8_t { kNone = 0, kPart = 1, kTable = 2, kClamp = 3, kRobot = 4, kOther = 5 };
const char* label_name(Label label);

/// Geom groups of a robot's meshes. MuJoCo collides a link's collision mesh as convex pieces
/// (kCollisionOnlyGroup: collided, never drawn or ray-cast); the mesh itself is what the part's clearance is
/// measured on, drawn and ray-cast too unless the link has visual meshes (then kClearanceOnlyGroup); visual
/// meshes (kVisualGroup) are drawn and ray-cast, never collided. MuJoCo's viewers hide groups from 3 on.
constexpr int kVisualGroup = 1;
constexpr int kCollisionOnlyGroup = 3;
constexpr int kClearanceOnlyGroup = 4;
/// Whether the geom is seen: drawn, and hit by the LiDAR's rays.
inline bool seen(const mjModel* m, int geom) {
  return m->geom_group[geom] < kCollisionOnlyGroup;
}
/// Whether the part's clearance is measured on the geom (primitives and collision meshes).
inline bool measured_for_clearance(const mjModel* m, int geom) {
  return m->geom_group[geom] == 0 || m->geom_group[geom] == kClearanceOnlyGroup;
}

/// Installs MuJoCo error/warning handlers that throw / collect instead of waiting for Enter and writing
/// MUJOCO_LOG.TXT. Idempotent; called by every function here that touches MuJoCo.
void install_mujoco_handlers();

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// Loads MJCF text (relative asset paths resolve against `base_dir`); throws InputError naming `source`.
ModelPtr load_mjcf(const std::string& xml, const std::string& base_dir, const std::string& source);

/// The MJCF of a whole cell: the environment file with the robot, part, clamps and clutter added.
std::string compose_cell_mjcf(const CellSpec& cell, const PartSpec& part, const RobotModel& robot,
                              const CellLayout& layout);

class MujocoWorld {
 public:
  /// Composes and loads the cell. Throws InputError for bad files.
  MujocoWorld(const CellSpec& cell, const PartSpec& part, const RobotModel& robot, const CellLayout& layout);

  const mjModel* model() const { return model_.get(); }
  mjData* data() const { return data_.get(); }
  const std::string& mjcf() const { return mjcf_; }
  /// A fresh mjData for another thread.
  DataPtr make_data() const { return DataPtr(mj_makeData(model_.get())); }

  /// Sets the arm's joints (URDF order) and runs mj_kinematics on `d`.
  void set_joints(mjData* d, const JointVector& q) const { set_joints(model_.get(), d, q); }
  /// The same with `m`, this world's model or a copy of it (the collision checker's, with its own margins and
  /// placements) that `d` was made for.
  void set_joints(const mjModel* m, mjData* d, const JointVector& q) const;
  Label geom_label(int geom) const { return geom_labels_[static_cast<size_t>(geom)]; }
  const std::vector<Label>& geom_labels() const { return geom_labels_; }
  /// Whether the layout places the geom (the part, a clamp, clutter); the others (the environment's and the
  /// arm's) are the same in every layout of the cell and come first, with the same ids.
  bool placed_by_layout(int geom) const { return placed_[static_cast<size_t>(geom)] != 0; }
  int body(const std::string& name) const;  ///< body id, throws std::out_of_range if missing
  /// qpos address of each arm joint, URDF order.
  const std::vector<int>& qpos_adr() const { return qpos_adr_; }
  /// The arm the world was composed with (its base is the world frame): its forward kinematics pose the
  /// arm's bodies wherever mj_kinematics is not wanted.
  const RobotModel& robot() const { return robot_; }
  /// The arm's link a body mirrors (RobotModel::links() index), -1 for a body that is not the arm's.
  int robot_link(int body) const { return body_link_.at(static_cast<size_t>(body)); }

 private:
  ModelPtr model_;
  DataPtr data_;
  std::string mjcf_;
  std::vector<int> qpos_adr_;  ///< qpos address of each URDF joint
  RobotModel robot_;
  std::vector<int> body_link_;  ///< per body: the arm's link, or -1
  std::vector<Label> geom_labels_;
  std::vector<char> placed_;  ///< per geom: placed by the layout
};

}  // namespace weldtwin
