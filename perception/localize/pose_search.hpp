// Stage 3 of the localizer: the global search over (x, y, yaw) on the table, no initial guess needed. Hough
// voting of oriented wall points of the scan against the model's wall samples at the same heights; the
// peaks, at least a bin apart, pre-ranked by a quick look (how many of a thin sample of points lie near the
// model there).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct PoseSearchSetting {
  int normal_neighbours = 24;     ///< points for each normal's PCA
  int vote_points = 1500;         ///< scan wall points that vote
  double vote_xy_m = 0.004;       ///< Hough bin size in x and y [m]
  double vote_yaw_deg = 2.0;      ///< Hough bin size in yaw [deg]
  int ranked_bins = 400;          ///< the best raw bins looked at for peaks
  int hypotheses = 36;            ///< Hough peaks looked at
  double distinct_xy_m = 0.01;    ///< peaks closer than this in x, y ... [m]
  double distinct_yaw_deg = 6.0;  ///< ... and in yaw are one peak [deg]
  /// At most this many peaks at one place (within distinct_xy_m), whatever their turn: a round thing votes
  /// for every turn at its centre, and would take every peak
  int max_turns_per_place = 8;
  int quick_look_points = 800;  ///< points of the quick look
  double quick_look_m = 0.006;  ///< a point within this of a model sample counts in the quick look [m]
};

/// A pose of the model on the table: T_table_part = planar_pose(x, y, 0, yaw).
struct Hypothesis {
  double x = 0, y = 0, yaw = 0;  ///< [m], [rad]
  int votes = 0;
};

struct PoseSearchResult {
  std::vector<Hypothesis> hypotheses;  ///< the distinct peaks, most promising first
  std::string reason;                  ///< why there are none
};

/// The search; `guess` (T_table_part, optional) is put first, beside the peaks. The quick looks on
/// `threads` threads (0: all cores).
PoseSearchResult search_poses(const ScenePoints& scene, PartModel& model, const PoseSearchSetting& setting,
                              const std::optional<Iso3>& guess = {}, int threads = 1);

}  // namespace weldtwin
