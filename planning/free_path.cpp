#include "planning/free_path.hpp"

#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <mutex>

namespace weldtwin {

std::vector<JointVector> free_joint_path(const JointVector& a, const JointVector& b, const JointVector& lower,
                                         const JointVector& upper,
                                         const std::function<bool(const JointVector&)>& is_free,
                                         double resolution_rad, long max_questions) {
  namespace ob = ompl::base;
  namespace og = ompl::geometric;
  // An end in collision has no path: answered at once, not after the whole budget of sampling.
  if (!is_free(a) || !is_free(b)) return {};
  // OMPL seeds every sampler it makes from one process-wide sequence: it starts over at every call (OMPL
  // complains when it is restarted; quiet), so that the same question gets the same answer whatever was asked
  // before in the process — a worker of `weldtwin bench` runs one trial after another. One call at a time.
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  ompl::RNG::setSeed(20261122);
  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  const int n = static_cast<int>(a.size());
  auto space = std::make_shared<ob::RealVectorStateSpace>(static_cast<unsigned>(n));
  ob::RealVectorBounds bounds(static_cast<unsigned>(n));
  // A transit needs no more than half a turn of a joint beyond its two ends: the space searched is no
  // wider (a vendor's +-360 deg joints would make it 2^6 times the volume of +-180 deg ones).
  for (int j = 0; j < n; ++j) {
    bounds.setLow(static_cast<unsigned>(j), std::max(lower[j], std::min(a[j], b[j]) - kPi));
    bounds.setHigh(static_cast<unsigned>(j), std::min(upper[j], std::max(a[j], b[j]) + kPi));
  }
  space->setBounds(bounds);
  og::SimpleSetup setup(space);
  auto to_q = [n](const ob::State* s) {
    const auto* v = s->as<ob::RealVectorStateSpace::StateType>();
    JointVector q;
    for (int j = 0; j < n; ++j) q[j] = v->values[j];
    return q;
  };
  long questions = 0;
  setup.setStateValidityChecker([&](const ob::State* s) {
    ++questions;
    return is_free(to_q(s));
  });
  // OMPL checks motions at a fraction of the space's extent: `resolution_rad` of joint travel.
  setup.getSpaceInformation()->setStateValidityCheckingResolution(resolution_rad / space->getMaximumExtent());
  ob::ScopedState<> start(space), goal(space);
  for (int j = 0; j < n; ++j) {
    start[static_cast<unsigned>(j)] = a[j];
    goal[static_cast<unsigned>(j)] = b[j];
  }
  setup.setStartAndGoalStates(start, goal);
  setup.setPlanner(std::make_shared<og::RRTConnect>(setup.getSpaceInformation()));
  setup.setup();
  // Given up after a number of questions, not of seconds: with a time limit the same question found a way on
  // a fast machine and none on a slow one (or a loaded one), and plans differed between machines.
  const ob::PlannerTerminationCondition stop = ob::plannerOrTerminationCondition(
      ob::PlannerTerminationCondition([&] { return questions >= max_questions; }),
      ob::exactSolnPlannerTerminationCondition(setup.getProblemDefinition()));
  if (setup.solve(stop) != ob::PlannerStatus::EXACT_SOLUTION) return {};
  setup.simplifySolution();
  std::vector<JointVector> path;
  for (const ob::State* s : setup.getSolutionPath().getStates()) path.push_back(to_q(s));
  path.front() = a;  // exactly the asked ends
  path.back() = b;
  return path;
}

bool joint_space_search_available() {
  return true;
}

}  // namespace weldtwin
