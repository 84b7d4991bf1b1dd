// A collision-free joint-space path between two free configurations, by OMPL's RRT-Connect (seeded afresh at
// every call, so the same question gets the same answer, whatever was asked before) and OMPL's path
// simplification. A build without OMPL (WELDTWIN_WITH_OMPL=OFF) finds no such path and says so.
#pragma once

#include <functional>
#include <vector>

#include "core/robot_model.hpp"

namespace weldtwin {

/// Waypoints from `a` to `b` (both included) whose straight joint-space segments are free according to
/// `is_free`, checked every `resolution_rad`; empty when none is found within `max_questions` calls of
/// `is_free` (a budget of questions, not of seconds: the answer does not depend on how fast the machine is),
/// and at once when `a` or `b` is not free. Each joint is searched within `lower`..`upper` and no more than
/// half a turn beyond the two ends.
std::vector<JointVector> free_joint_path(const JointVector& a, const JointVector& b, const JointVector& lower,
                                         const JointVector& upper,
                                         const std::function<bool(const JointVector&)>& is_free,
                                         double resolution_rad = 0.02, long max_questions = 100000);

/// Whether this build searches joint space at all (false: built without OMPL, free_joint_path finds nothing).
bool joint_space_search_available();

}  // namespace weldtwin
