// Which side of its walls the scan is on, for clouds without viewpoints. Under range noise close to a thin
// wall's thickness, the scan fitted to the other side of every wall (the part moved by one wall thickness)
// is a local minimum of any fit, and a search started on that side stays there. So the surface fit
// (surface_icp.hpp) is started from the best pose, from where that fit settled moved across the part's thin
// walls (PartModel::wall_side_shifts), and from the distinct rival poses of the search, on one set of points;
// the lowest cost wins, and its margin over the best distinct other weld, as a log-likelihood ratio, says how
// sure that is.
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/surface_icp.hpp"

namespace weldtwin {

struct WallSideSetting {
  double distinct_seam_m = 0.0005;  ///< fits whose seams lie this far apart are different welds [m]
  int max_rounds = 3;               ///< rounds of moves across the walls from the best fit so far
  double retry_m = 0.001;           ///< a move starting this close to an earlier start is not made again [m]
};

struct WallSideResult {
  SurfaceFit best;
  PoseUncertainty uncertainty;  ///< of `best`
  /// The log-likelihood ratio of `best` over the best fit that welds elsewhere: the cost difference in the
  /// residuals' own variance, over the design effect (+inf: no such fit).
  double margin_llr = 0.0;
  double rival_offset_m = 0.0;  ///< how far that fit puts the seams from `best`'s [m]
  /// The same ratio over that fit from the residuals alone, without the view prior (negative: the
  /// residuals prefer the other fit, and only the prior chose `best`).
  double residual_margin_llr = 0.0;
  int fits = 0;
};

/// Fits from every start (table frame -> part frame) on the points near any of them, and from where the best
/// fit settled moved across the part's thin walls (PartModel::wall_side_shifts), for as long as that finds
/// a better fit; `seams` (part frame) say which fits weld the same place.
WallSideResult decide_wall_side(const std::vector<ScanPoint>& icp_points, const PartModel& model,
                                const std::vector<Iso3>& starts, const std::vector<Vec3>& seams,
                                double noise_m, const SurfaceIcpSetting& surface,
                                const PoseUncertaintySetting& uncertainty, const WallSideSetting& setting,
                                int threads);

}  // namespace weldtwin
