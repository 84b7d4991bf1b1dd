// `weldtwin bench`: the randomized-pose benchmark — many random cells, each swept, localized by ours and by
// the paper's pipeline on the same scan, planned and replayed, one JSON line per trial; and
// `weldtwin bench-report`: shards merged into a summary and an HTML page with plots.
//
// Trials are independent and seeded by (seed, index) only, so any split into shards (--shard K/N) run on any
// machines gives, merged, exactly the lines of one long run. Each trial runs in a child process: a crash or a
// hang is recorded as that trial's failure, with its cause, and the run goes on.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/cell_spec.hpp"  // PlacementSpec

namespace weldtwin {

struct BenchCommand {
  int trials = 100;  ///< trial indices 0 .. trials-1 (of which this shard runs its share)
  uint64_t seed = 1;
  int jobs = 0;   ///< trials in flight at once (worker processes); 0: one per core
  int shard = 0;  ///< this shard, 0 .. shards-1: runs the indices i with i % shards == shard
  int shards = 1;
  std::string out;                 ///< JSON lines, in index order
  std::vector<std::string> cells;  ///< the parts' cells, drawn among uniformly ("" = the three of scenes/)
  bool paper = true;               ///< the paper's pipeline on every scan, side by side
  bool replay = true;              ///< plan and replay (off: localization only)
  bool weld_window = true;         ///< the planner may search the seams' angle windows, directions and order
  double replay_step_s = 0.005;    ///< physics step of the replay (weldtwin run: 2.5 ms; see ReplaySetting)
  double timeout_s = 600.0;        ///< a trial running longer is killed and recorded as a timeout
  double mount_error_m = 0.0;      ///< LiDAR mount error drawn per trial: translation sigma per axis [m]
  double mount_error_rad = 0.0;    ///< and rotation sigma per axis [rad]
  double encoder_noise_rad = 0.0;  ///< joint encoder noise (sigma) on the recorded joint states [rad]
  std::string sweep;               ///< sweep program for every cell ("" = each cell's own, and its rescan)
  /// Swept one after another while the part is not found in the sweeps so far, the part then sought in all
  /// of them (none: the cell's own `rescan:`, if any and no other sweep is given); each starts where the
  /// program before it ends
  std::vector<std::string> rescans;
  std::string robot;  ///< robot file (arm and tooling) for every cell ("" = each cell's own)
  std::optional<PlacementSpec::Area>
      placement;  ///< where parts are drawn in every cell (unset: each cell's own)
  bool guidance =
      false;  ///< a failed trial whose part was found right: where to put it, tried as a trial of its own
  bool viewpoints = true;  ///< localize with every point's viewpoint (off: as other tools' clouds)
  bool calibrate =
      false;  ///< find each trial's mount from a sweep of the calibration cell first (as weldtwin calibrate)
  bool quiet = false;
  bool resume = false;      ///< keep the finished lines already in `out` (a stopped run) and run the rest
  std::string keep_failed;  ///< DIR: a failed trial's scan, poses and plan go to DIR/trial-INDEX/
  std::vector<std::string> faults;  ///< for tests: "INDEX:crash|hang|throw" makes that trial misbehave
};

/// Runs the benchmark. Returns 0 when every trial was run and recorded (whatever their verdicts), 2 for bad
/// input.
int run_bench(const BenchCommand& cmd);

/// One trial of `cell_file` laid out by `layout_seed` and swept with LiDAR noise `lidar_seed` (as `weldtwin
/// run CELL --seed N` does with N for both), run in this process, as its bench line. For checks that the two
/// commands agree.
nlohmann::json bench_trial_at(const BenchCommand& cmd, const std::string& cell_file, uint64_t layout_seed,
                              uint64_t lidar_seed);

struct BenchReportCommand {
  std::vector<std::string> inputs;  ///< JSON-lines files (shards) of one benchmark
  std::string out = "out/bench";    ///< DIR: results.jsonl (merged), summary.json, report.html
};

/// Merges the shards and writes the summary and the page. Returns 0, or 2 for bad input (unreadable or
/// malformed lines, shards of different benchmarks, the same trial with different results).
int run_bench_report(const BenchReportCommand& cmd);

}  // namespace weldtwin
