// Stage 4 of the localizer: (x, y, yaw) point-to-plane ICP of scan points (table frame) onto the model, the
// table fixing the rest. A correspondence counts only on a visible sample away from feature edges, with a
// residual within the cut-off, the trim and half the wall behind it: each limit symmetric about the surface,
// so that noise does not push the answer one way. Coarse refinement starts with closed-form point-to-point
// steps; fine refinement handles thin walls and, where the rays are known, matches each with the face it
// meets (ray_matching.hpp). Without rays, the outline of a part too low to be told from the table is read
// from the height step across it.
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/ray_matching.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct PlanarIcpSetting {
  int point_to_point_iterations = 3;  ///< closed-form steps before the coarse point-to-plane ones
  int coarse_iterations = 12;
  int coarse_points = 2500;  ///< scan points used per coarse iteration (evenly thinned)
  int fine_iterations = 25;
  int fine_points = 12000;          ///< scan points used per fine iteration (evenly thinned)
  double start_distance_m = 0.012;  ///< correspondence cut-off at the first iteration [m]
  double trim_sigmas = 2.5;         ///< residuals beyond this many noise sigmas are not used
  double edge_margin_sigmas = 0.5;  ///< model samples this close to a feature edge are not used
  double in_plane_spacings = 3.0;   ///< a match's offset along its face, in model sample spacings
  int min_correspondences = 20;     ///< fewer: the step is not taken
  double yaw_lever_m = 0.1;         ///< converged: yaw step x this + translation step below ...
  double converged_step_m = 1e-6;   ///< ... this [m]
  double box_margin_m = 0.02;       ///< points this far beyond the model's box take no part [m]
  double level_normal_z = 0.95;     ///< points deep on a face this level take no part ...
  double level_depth_m = 0.004;     ///< ... within this of it [m]
  // The outline read from the height step (parts too low for their walls to be told from the table).
  int outline_steps = 17;               ///< cells looked at across the outline, 1 mm apart
  double outline_step_m = 0.001;        ///< [m]
  int outline_min_known = 10;           ///< of them, at least this many seen
  double outline_max_offset_m = 0.006;  ///< an edge found farther away is not this edge [m]
  RayMatchSetting rays;
};

struct IcpResult {
  Iso3 P = Iso3::Identity();  ///< table frame -> part frame
  int iterations = 0;
  bool converged = false;
  std::vector<ResidualTerm> terms;  ///< the last iteration's residuals (fine refinement only)
  /// With rays, the rays of the last iteration matched with a face whose residual lay beyond the trim: not in
  /// the fit (a clamp, a blend, or the scan off the model there), their residuals clipped at the trim
  std::vector<ResidualTerm> beyond_trim;
};

/// The points around a pose that can move (x, y, yaw): those nearest a face that is not level (a level
/// face's residual does not change with them).
std::vector<ScanPoint> points_near_pose(const std::vector<ScanPoint>& from, PartModel& model, const Iso3& P,
                                        const PlanarIcpSetting& setting = {});

/// ICP from P for `iterations`; `fine` as in the file comment.
IcpResult planar_icp(const std::vector<ScanPoint>& scan, const ScenePoints& scene, PartModel& model, Iso3 P,
                     int iterations, bool fine, const PlanarIcpSetting& setting = {});

}  // namespace weldtwin
