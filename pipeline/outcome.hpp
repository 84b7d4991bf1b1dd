// Outcomes as values: why a weld job (a `weldtwin run`, a bench trial) did not pass, as a kind beside its
// human reason, and the process's exit code derived from kinds in this one place.
#pragma once

#include <string>
#include <vector>

namespace weldtwin {

/// Exit codes of every command (docs/design.md).
constexpr int kExitPassed = 0;
constexpr int kExitBadInput = 2;       ///< a file or an option is wrong: nothing was judged
constexpr int kExitUntrustworthy = 3;  ///< judged, and refused (not found, not planned, not replayed clean)
constexpr int kExitInterrupted = 130;  ///< Ctrl-C stopped the arm

enum class FailureKind {
  kPartNotFound,  ///< the localizer refused: no part, an ambiguous or a poor fit
  kLocalization,  ///< the part was accepted, but its seams lie off the truth beyond the weld tolerance
                  ///< (known only where the truth is: the twin)
  kPlan,          ///< a seam cannot be welded (WeldPlan::failure says how)
  kReplay,        ///< the plan failed its replay in the twin
  kRobot,         ///< the arm failed or was stopped
  kError,         ///< the job threw: an input the job could not use
  kCrash,         ///< a bench trial's process died
  kTimeout,       ///< a bench trial ran past its time and was killed
};

/// The kind's name as the lines and reports print it ("part not found", "plan", ...).
const char* failure_kind_name(FailureKind kind);

struct Failure {
  FailureKind kind = FailureKind::kError;
  std::string reason;  ///< what a person can act on
  /// "kind: reason", as the reports and the bench's lines carry it.
  std::string text() const { return std::string(failure_kind_name(kind)) + ": " + reason; }
};

/// "limit 1 mm": a weld tolerance as the verdict lines print it.
std::string tolerance_text(double weld_tolerance_m);

/// The exit code of a job that ran to its verdict: 0 when nothing failed, 130 when the first failure is
/// the arm stopped on request, 3 otherwise.
int exit_code(const std::vector<Failure>& failures, bool stop_requested = false);

}  // namespace weldtwin
