#include "pipeline/outcome.hpp"

#include <cstdio>

namespace weldtwin {

const char* failure_kind_name(FailureKind kind) {
  switch (kind) {
    case FailureKind::kPartNotFound:
      return "part not found";
    case FailureKind::kLocalization:
      return "localization";
    case FailureKind::kPlan:
      return "plan";
    case FailureKind::kReplay:
      return "replay";
    case FailureKind::kRobot:
      return "robot";
    case FailureKind::kError:
      return "error";
    case FailureKind::kCrash:
      return "crash";
    case FailureKind::kTimeout:
      return "timeout";
  }
  return "error";
}

std::string tolerance_text(double weld_tolerance_m) {
  char b[48];
  std::snprintf(b, sizeof b, "limit %g mm", 1e3 * weld_tolerance_m);
  return b;
}

int exit_code(const std::vector<Failure>& failures, bool stop_requested) {
  if (failures.empty()) return kExitPassed;
  if (failures.front().kind == FailureKind::kRobot && stop_requested) return kExitInterrupted;
  return kExitUntrustworthy;
}

}  // namespace weldtwin
