// The refinement for clouds without viewpoints: (x, y, yaw) ICP of the scan onto the part's exact surface.
// Each point is matched with the nearest point of the mesh itself (Embree's point query), found from its
// neighbourhood centroid (whose noise is a fraction of the point's own) and measured from the point along
// the direction to it: a face's normal inside it, the direction to the edge or corner beyond it. Both faces
// of a thin wall take part, the walls' ends, a tube's rim and a plate's top edges too: no sample is left
// out, so nothing makes the wrong side of a wall fit as well as the right one by leaving points out. Robust
// weights (Tukey's biweight) keep clamps and clutter touching the part out of the fit. Its cost, summed
// over one set of points, compares poses (the wall-side alternatives, wall_side.hpp); its residuals give
// the pose's uncertainty (pose_uncertainty.hpp).
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/scene_points.hpp"
#include "perception/localize/view_prior.hpp"

namespace weldtwin {

struct SurfaceIcpSetting {
  int iterations = 20;
  double kernel_sigmas = 2.5;   ///< Tukey's cut-off in range noise sigmas ...
  double min_kernel_m = 0.003;  ///< ... and at least this [m]
  int max_points = 4000;        ///< scan points used (evenly thinned)
  double box_margin_m = 0.01;   ///< points this far beyond the model's box take part [m]
  /// A step below this (yaw times yaw_lever_m + translation) ends it: a hundredth of the range noise, against
  /// pose bounds of hundreds of micrometres. (1 um let fits wander for their last steps: the steps minimise
  /// the residuals, not the view prior the cost also holds.) [m]
  double converged_step_m = 1e-5;
  int coarse_stride = 4;        ///< first steps on every this many points (1: none), at most ...
  int coarse_iterations = 15;   ///< ... this many (besides `iterations` on all of them) ...
  double coarse_step_m = 2e-5;  ///< ... until a step is shorter than this [m]
  double yaw_lever_m = 0.1;
  double damping = 1e-9;  ///< added to the normal equations' diagonal
  /// How likely the points are on the faces they are matched with, for a scanner somewhere above
  /// (view_prior.hpp): the cost adds its nats, so that the scan of a wall's outer face does not fit the
  /// inner face (seen only past the rim) as well.
  ViewPriorSetting view;
};

struct SurfaceFit {
  Iso3 P = Iso3::Identity();  ///< table frame -> part frame
  int iterations = 0;
  bool converged = false;
  double cost = 0.0;                ///< sum of Tukey's rho over the points, in units of the noise variance,
                                    ///< plus the view prior [nats]
  double view_nats = 0.0;           ///< the view prior's part of the cost [nats]
  int inliers = 0;                  ///< points with non-zero weight
  std::vector<ResidualTerm> terms;  ///< the residuals at P
  /// How far the scan's surfaces are from the model's, by the distance of the points' neighbourhood
  /// centroids to the mesh (noise averages out there, shape does not): the median over the points on walls,
  /// and the median signed height of those on level faces (positive: the scan above the model) [m].
  double wall_offset_m = 0.0, level_offset_m = 0.0;
  double wall_sigma_m = 0.0;  ///< robust spread of the residuals on walls (1.4826 MAD) [m]
};

/// The points to fit near pose P (the model's box grown by box_margin_m + extra_margin_m), thinned.
std::vector<ScanPoint> surface_points(const std::vector<ScanPoint>& from, const PartModel& model,
                                      const Iso3& P, double extra_margin_m,
                                      const SurfaceIcpSetting& setting = {});

/// ICP from P; `noise_m` is the range noise sigma.
SurfaceFit surface_icp(const std::vector<ScanPoint>& points, const PartModel& model, Iso3 P, double noise_m,
                       const SurfaceIcpSetting& setting = {});

/// The cost and residuals at P without moving it.
SurfaceFit surface_cost(const std::vector<ScanPoint>& points, const PartModel& model, const Iso3& P,
                        double noise_m, const SurfaceIcpSetting& setting = {});

}  // namespace weldtwin
