// Finding a part in a base-frame cloud of a table scene, with figures that say how far to trust the answer.
// The part rests on the table: the table plane (cascaded RANSAC) fixes roll, pitch and height, and the
// remaining (x, y, yaw) is searched globally by Hough voting of oriented wall points against the model — no
// initial guess, no region of interest. Each peak is refined by robust point-to-plane ICP that registers the
// scan onto the model (so faces the sensor never saw bias nothing), and the verdict weighs fit, coverage of
// the model and ambiguity between distinct poses (poses the part's own symmetry maps onto each other are
// equal).
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "perception/mesh_io.hpp"

namespace weldtwin {

struct LocalizeSetting {
  double reach_radius_m = 1.2;       ///< the table is sought within this distance of the base axis
  double table_threshold_m = 0.004;  ///< RANSAC inlier distance for the table plane
  double table_max_tilt_deg = 15.0;  ///< the table plane's normal is within this angle of +z
  double min_height_m = 0.005;       ///< points at least this far above the table belong to objects
  double base_keepout_m = 0.12;      ///< points this close to the base axis are the robot's base
  double voxel_m = 0.002;            ///< voxel edge for the object points
  double model_spacing_m = 0.002;    ///< model surface sample spacing
  int normal_neighbours = 12;        ///< points for each normal's PCA
  double vote_xy_m = 0.004;          ///< Hough bin size in x and y
  double vote_yaw_deg = 2.0;         ///< Hough bin size in yaw
  int hypotheses = 6;                ///< Hough peaks refined
  int icp_iterations = 30;
  int icp_max_points = 4000;            ///< scan points used per ICP iteration (evenly thinned)
  double icp_start_distance_m = 0.010;  ///< correspondence cut-off at the first ICP iteration
  double icp_end_distance_m = 0.003;    ///< and at the last
  double huber_m = 0.001;               ///< robust kernel width
  double inlier_m = 0.003;              ///< |point-to-plane residual| of an inlier
  double min_coverage = 0.25;           ///< fraction of the model's samples that must have scan points nearby
  double max_rmse_m = 0.0025;           ///< inlier RMSE above which the fit is poor
  double min_fitness = 0.5;             ///< inlier fraction of the scan points on and around the model
  double ambiguity_ratio = 0.9;         ///< a distinct pose scoring this close to the best is ambiguous
};

struct PoseEstimate {
  bool found = false;
  std::string reason;  ///< why not found: no table, no part, poor fit, ambiguous
  Iso3 T_base_part = Iso3::Identity();
  double fitness = 0.0, rmse_m = 0.0, coverage = 0.0;
  double ambiguity = 0.0;  ///< score of the best distinct non-equivalent pose over the best's
  bool converged = false;
  int iterations = 0;
  int inliers = 0;
  Eigen::Vector4d table_plane = Eigen::Vector4d::Zero();  ///< n.x + d = 0, n up, base frame
  int object_points = 0;                                  ///< points above the table after voxelisation
  double seconds = 0.0;
};

/// Localizes `model` (part frame, resting on z = its lowest vertex) in `scan_base`. `seam_points` (part
/// frame, optional) are points along the part's weld seams, about 1 mm apart: two poses that map them onto
/// each other weld the same place, so they are not ambiguous even where the mesh itself is not symmetric (a
/// round tube on a square plate).
PoseEstimate localize(const std::vector<Vec3>& scan_base, const Mesh& model,
                      const LocalizeSetting& setting = {}, const std::vector<Vec3>& seam_points = {});

}  // namespace weldtwin
