// How far to trust a planar pose: the covariance of (yaw, x, y) from the final fit's residuals, and the bound
// it puts on how far any seam point may be from where the pose puts it.
//
// The covariance is the cluster-robust sandwich of an M-estimator (White 1980; Liang and Zeger 1986):
// Cov = H^-1 (sum_c g_c g_c^T) H^-1, H = sum_i w_i J_i J_i^T, g_c = sum_{i in c} w_i J_i r_i over the points
// of each spatial cell c. Neighbouring points share their errors (voxels, smoothing, a warped stretch of
// wall), and the residuals say how large those errors really are: a miscalibrated or deformed scan fits worse
// and gets a wider bound, where the noise alone would promise more than the scan can keep.
//
// The sums of a few cells say little of their own spread: a direction the scan holds by a handful of cells
// (a tube seen across, its place along its length held by the few rays that met its ends) gets a quantile
// widened as Student's t widens an interval estimated from that many (the count is per direction, of the
// form (sum l)^2 / sum l^2 of Satterthwaite's degrees of freedom, as Bell and McCaffrey 2002 give each
// contrast its own). Without it, five cells each off by its own error left the bound
// holding in 94 % of draws where it states 95 %.
#pragma once

#include <limits>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// One residual of a planar fit: r (metres) and its derivative J w.r.t. (yaw, x, y) of the part, its
/// robust weight, and where it is (part frame) for the clustering.
struct ResidualTerm {
  Vec3 J = Vec3::Zero();
  double r = 0.0;
  double w = 1.0;
  Vec3 at = Vec3::Zero();
  /// An error of about this size besides the range noise that the residuals cannot show, the same for the
  /// residuals of one cell (a bias: mixed pixels at a depth edge seen from one side) [m].
  double unseen_sigma_m = 0.0;
};

struct PoseUncertaintySetting {
  double cluster_cell_m = 0.01;  ///< residuals in one cell of this edge share their errors [m]
  double confidence = 0.95;      ///< the bounds' level (a 3-dof region: 2.8 sd with many cells)
};

struct PoseUncertainty {
  bool ok = false;                 ///< false: too few residuals, or some motion they do not constrain
  Mat3 covariance = Mat3::Zero();  ///< of (yaw [rad], x [m], y [m]), part-frame perturbation
  int clusters = 0;
  double residual_sigma_m = 0.0;  ///< weighted RMS of the residuals [m]
  /// How much wider the sandwich is than independent residuals of that RMS would make it (the largest
  /// eigenvalue of Cov_model^-1 Cov): >1 where neighbouring errors are shared.
  double design_effect = 1.0;
  /// H^-1, and the second moments sum_g h_g h_g^T of the cells' shares H_g of H = sum_i w_i J_i J_i^T, each
  /// as h_g = (H00, H11, H22, H01, H02, H12): how many cells inform a given motion (effective_cells).
  Mat3 information_inverse = Mat3::Zero();
  Eigen::Matrix<double, 6, 6> cell_information_moments = Eigen::Matrix<double, 6, 6>::Zero();
};

/// The covariance of the fit whose final residuals are `terms`.
PoseUncertainty pose_uncertainty(const std::vector<ResidualTerm>& terms,
                                 const PoseUncertaintySetting& setting = {});

/// How many cells effectively inform the motion c^T (yaw, x, y): 1 / sum_g l_g^2 over the cells' leverages
/// l_g = c^T H^-1 H_g H^-1 c / c^T H^-1 c (which sum to 1). A direction that rests on a handful of cells (the
/// ends of a tube seen across) has few, however many cells the fit has. 0 when `u` is not ok.
double effective_cells(const PoseUncertainty& u, const Vec3& c);

/// The squared scale of the bounds' confidence region when `cells` cells inform the direction bounded:
/// chi-square's 3-dof quantile at the setting's confidence for many cells (cells = +inf gives exactly it),
/// widened as they become few by how much Student's t with cells - 1 degrees of freedom widens a two-sided
/// interval over the normal's (a spread estimated from a few cells' sums is itself uncertain; 4.0 sd for 5
/// cells, 3.0 for 20, against 2.8). +inf for 2 cells or fewer.
double confidence_scale2(double cells, const PoseUncertaintySetting& setting = {});

/// How point p (part frame) moves under the perturbation (yaw, x, y): its (x, y) move per unit of each.
Eigen::Matrix<double, 2, 3> planar_move_jacobian(const Vec3& p);

/// The largest displacement of any of `points` (part frame) within the 95 % confidence region of `u`: a
/// bound on the seam error when the points are the seams. Each point's two principal directions of move take
/// the quantile of the cells that hold the pose along them (their count rounded down: never narrower).
struct SeamBound {
  double bound_m = std::numeric_limits<double>::infinity();  ///< +inf when `u` is not ok [m]
  Eigen::Vector2d direction = Eigen::Vector2d::Zero();       ///< of that displacement (part frame, unit)
  double cells = 0.0;  ///< how many cells effectively inform the pose along it (effective_cells)
};
SeamBound seam_error_bound(const PoseUncertainty& u, const std::vector<Vec3>& points,
                           const PoseUncertaintySetting& setting = {});
/// Its bound alone [m].
double seam_error_bound_m(const PoseUncertainty& u, const std::vector<Vec3>& points,
                          const PoseUncertaintySetting& setting = {});

/// The largest turn about the table normal within the 95 % confidence region of `u` [rad]; +inf when `u`
/// is not ok.
double yaw_bound_rad(const PoseUncertainty& u, const PoseUncertaintySetting& setting = {});

/// What a fit without viewpoints may be off by across walls of thickness `t_m` whose points spread by
/// `sigma_m`: a point thrown beyond the wall's middle is taken for the other face (share q = Phi(-t / 2
/// sigma)) and moves the fitted face by about t; the two faces' shares may act the same way: 2 q t [m].
/// 0 for no thin walls.
double wall_side_bias_m(double t_m, double sigma_m);

}  // namespace weldtwin
