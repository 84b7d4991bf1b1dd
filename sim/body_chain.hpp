// Forward kinematics of one MuJoCo body straight from the compiled model (body offsets and hinge axes),
// without mj_kinematics: cheap enough to pose the LiDAR at every one of its samples. Hinge joints only.
#pragma once

#include <limits>
#include <vector>

#include <mujoco/mujoco.h>

#include "core/robot_model.hpp"

namespace weldtwin {

class BodyChain {
 public:
  /// The chain from the world to `body`; `qpos_adr[i]` is the qpos address of joint i of the arm (URDF
  /// order).
  BodyChain(const mjModel* m, int body, const std::vector<int>& qpos_adr);
  /// T_world_body for arm joints q.
  Iso3 pose(const JointVector& q) const;

  /// Products of the chain from each link to the end, kept between calls: when only the first joints change
  /// (a base-joint pass), only their part of the product is recomputed. One per thread.
  struct Cache {
    JointVector q = JointVector::Constant(std::numeric_limits<double>::quiet_NaN());
    std::vector<Mat3> R;  ///< rotation of the suffix product starting at link k
    std::vector<Vec3> p;  ///< its translation
  };
  /// The same pose as pose(q), reusing `cache`; equal to it to rounding (the products are associated
  /// differently).
  Iso3 pose(const JointVector& q, Cache& cache) const;

 private:
  struct Link {
    Iso3 T_parent_body;
    int q_index = -1;  ///< arm joint turning this body, -1 if fixed
    Vec3 axis = Vec3::UnitZ();
    bool axis_is_z = false;
  };
  std::vector<Link> links_;  ///< root first
  /// R := R * Rot(l.axis, q[l.q_index]) for a jointed link.
  static void turn(const Link& l, const JointVector& q, Mat3& R);
};

}  // namespace weldtwin
