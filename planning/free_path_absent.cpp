// Joint-space paths in a build without OMPL (WELDTWIN_WITH_OMPL=OFF): none found, and the planner says why.
#include "planning/free_path.hpp"

namespace weldtwin {

std::vector<JointVector> free_joint_path(const JointVector&, const JointVector&, const JointVector&,
                                         const JointVector&, const std::function<bool(const JointVector&)>&,
                                         double, long) {
  return {};
}

bool joint_space_search_available() {
  return false;
}

}  // namespace weldtwin
