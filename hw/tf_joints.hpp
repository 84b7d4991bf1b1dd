// Arm poses recorded as transforms (/tf, as robot_state_publisher publishes a URDF robot's links) instead of
// joint states: each actuated joint's transform from its parent link to its child link is the URDF's joint
// origin turned by the joint's angle about its axis, so the angle is read back from the transform, and
// checked to be one (an origin or an axis that is not the URDF's is refused: another robot description).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "core/robot_model.hpp"

namespace weldtwin {

/// One transform of a tf2_msgs/TFMessage.
struct TfTransform {
  int64_t stamp_ns = 0;
  std::string parent, child;  ///< frame names (a leading '/' is ignored)
  Iso3 T_parent_child = Iso3::Identity();
};

struct StampedJoints {
  int64_t stamp_ns = 0;
  JointVector q = JointVector::Zero();  ///< [rad], in the robot's joint order
};

/// The robot's joint angles from its links' transforms: one sample at every stamp of the first joint's
/// transforms that every other joint's transforms span (those joints interpolated linearly between their
/// two nearest stamps). Throws InputError naming `file` when a joint has no transform (naming the frames the
/// recording has), or a transform is not the URDF's joint (its origin 0.1 mm or more away, or a turn about
/// another axis).
std::vector<StampedJoints> joints_from_tf(const std::vector<TfTransform>& tf, const RobotModel& robot,
                                          const std::string& file);

/// The transforms robot_state_publisher would publish for joint angles `q` at `stamp_ns`: one per actuated
/// joint (`moving`), or one per fixed joint (its /tf_static).
std::vector<TfTransform> tf_of_joints(int64_t stamp_ns, const JointVector& q, const RobotModel& robot,
                                      bool moving = true);

}  // namespace weldtwin
