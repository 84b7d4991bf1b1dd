// Finding a part in a base-frame cloud of a table scene, with figures that say how far to trust the answer.
// The recipe (localizer.cpp) runs the stages in perception/localize/, one file each:
// clang-format off
//   part_model        the mesh made ready: samples, visibility, thickness, edges, footprint (PreparedPart)
//   table_plane       the table (cascaded RANSAC, refitted away from what stands on it) and the range noise
//   scene_points      the scan's points in the table frame: objects, the cells near the table, the rays
//   pose_search       (x, y, yaw) by Hough voting of oriented wall points, no initial guess needed
//   planar_icp        (x, y, yaw) point-to-plane ICP with symmetric trimming (ray_matching: by rays, when
//                     the cloud carries every point's viewpoint)
//   refinement        the peaks refined in batches until one is allowed by the scan
//   pose_score        inliers, coverage, free space, the walls' residual (see_through: what the rays say)
//   surface_icp       without viewpoints: the fit onto the mesh's exact surface (wall_side: across the walls)
//   pose_uncertainty  the covariance of the fit and the 95 % bounds on the seams and the yaw
//   part_extent       the scan going on past the model's edges
//   verdict           ambiguity between distinct poses, and the figures against their limits
// clang-format on
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry.hpp"
#include "perception/localize/part_extent.hpp"
#include "perception/localize/part_model.hpp"
#include "perception/localize/pass_agreement.hpp"
#include "perception/localize/planar_icp.hpp"
#include "perception/localize/pose_score.hpp"
#include "perception/localize/pose_search.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/refinement.hpp"
#include "perception/localize/scene_points.hpp"
#include "perception/localize/see_through.hpp"
#include "perception/localize/surface_icp.hpp"
#include "perception/localize/table_plane.hpp"
#include "perception/localize/verdict.hpp"
#include "perception/localize/wall_patches.hpp"
#include "perception/localize/wall_side.hpp"
#include "perception/mesh_io.hpp"

namespace weldtwin {

struct LocalizeSetting {
  TablePlaneSetting table;
  ScenePointsSetting scene;
  PartModelSetting model;
  PoseSearchSetting search;
  PlanarIcpSetting icp;
  PoseScoreSetting score;
  PartExtentSetting extent;
  SeeThroughSetting see_through;
  VerdictSetting verdict;
  SurfaceIcpSetting surface;
  PoseUncertaintySetting uncertainty;
  WallSideSetting wall_side;
  RefineSetting refine;
  PassAgreementSetting passes;
  WallPatchSetting wall_patches;
  int threads = 0;  ///< hypotheses refined side by side (0: all cores)
  // Optional rough pose (T_base_part) from elsewhere: refined first, beside the peaks of the global search.
  bool use_initial_guess = false;
  Iso3 initial_guess = Iso3::Identity();
};

struct PartSpec;

/// The localizer's setting for `part`: `base` with the part's weld tolerance as the bound a pose must meet.
LocalizeSetting localize_setting_for(const PartSpec& part, LocalizeSetting base = {});

struct PoseEstimate {
  bool found = false;
  std::string reason;  ///< why not found: no table, no part, poor fit, ambiguous
  Iso3 T_base_part = Iso3::Identity();
  double fitness = 0.0, rmse_m = 0.0, coverage = 0.0;
  double free_space = 0.0;     ///< fraction of the footprint where the scan sees the table through the part
  double ambiguity = 0.0;      ///< score of the best distinct non-equivalent pose over the best's
  double noise_m = 0.0;        ///< range noise sigma estimated from the table
  double wall_residual = 0.0;  ///< median |residual| of the scan points on the model's walls, in noise sigmas
  /// With viewpoints: the share of the rays meeting the model's walls in patches of them off the model's
  /// (wall_patches.hpp), the largest such patch's centre (part frame, mesh units) and its mean residual
  /// (positive: the scan outside the wall) [m]
  double wall_patch_share = 0.0;
  Vec3 wall_patch_at_part = Vec3::Zero();
  double wall_patch_offset_m = 0.0;
  bool converged = false;
  int iterations = 0;
  int inliers = 0;
  Eigen::Vector4d table_plane = Eigen::Vector4d::Zero();  ///< n.x + d = 0, n up, base frame
  int object_points = 0;                                  ///< points above the table after voxelisation
  bool rays_cast = false;  ///< refined by casting each point's ray from its viewpoint (the cloud had them)
  double seam_error_bound_m = 0.0;  ///< 95 % bound on any seam point's error from the fit (+inf: unbounded)
  /// The direction (part frame, level) in which the fit leaves the seams most uncertain, and how many of the
  /// scan's 1 cm cells effectively hold the pose that way (pose_uncertainty.hpp: effective_cells)
  Vec3 bound_direction_part = Vec3::Zero();
  double bound_cells = 0.0;
  double yaw_bound_rad = 0.0;      ///< 95 % bound on the part's turn about the table normal (+inf: unbounded)
  Mat3 covariance = Mat3::Zero();  ///< of (yaw [rad], x [m], y [m]) of the part, its own frame
  /// Without viewpoints: the log-likelihood ratio of the pose over the best fit that welds elsewhere (the
  /// scan on the other side of the walls, a rival of the search); +inf: none was found.
  double margin_llr = 0.0;
  double rival_offset_m = 0.0;       ///< how far that fit puts the seams from this pose's [m]
  double residual_margin_llr = 0.0;  ///< ... the same from the residuals alone, without the view prior
  /// With viewpoints, when a distinct pose has support: how far the strongest rival puts the seams
  /// (rival_offset_m, above) and its turn from this pose [rad]
  double rival_turn_rad = 0.0;
  double wall_offset_m =
      0.0;  ///< without viewpoints: median distance of the scan's walls from the model's [m]
  double level_offset_m = 0.0;  ///< ... and median height of its level faces above the model's [m]
  double wall_sigma_m = 0.0;    ///< without viewpoints: spread of the residuals on walls [m]
  /// Share of the model's faces continued past its convex edges on which the scan has points (the part is
  /// larger than the model there), and where those lie (part frame, mesh units) [m].
  /// With viewpoints: the share of the rays crossing the model's box that went through the model (the point
  /// seen well behind the model's surface on its ray).
  double see_through_share = 0.0;
  /// With viewpoints: the region of the model where most rays went through it away from its depth edges
  /// (see_through.hpp): how many, of how many that met the model there, and its centre (part frame, mesh
  /// units) [m]
  int region_through = 0, region_rays = 0;
  Vec3 region_at_part = Vec3::Zero();
  /// With viewpoints: the share of the model's samples the sweep's rays reached that the scan confirms (what
  /// one short pass could have seen of the part; -1 when the rays reached none).
  double reached_coverage = -1.0;
  double beyond_share = 0.0;
  double beyond_extent_m = 0.0;        ///< the longest stretch of them [m] ...
  Vec3 beyond_at_part = Vec3::Zero();  ///< ... and its centre
  /// The one wall continued up past one straight top edge into open air the scan supports most
  /// (part_extent.hpp): the share of it with scan points on it, the edge's length and where (part frame) [m]
  double beyond_line_share = 0.0;
  double beyond_line_length_m = 0.0;
  Vec3 beyond_line_at_part = Vec3::Zero();
  /// Without viewpoints: what the bound allows for points taken for the other face of a thin wall [m].
  double wall_side_bias_m = 0.0;
  /// With viewpoints: how much the seam bound grows when the rays near the model's depth edges carry a
  /// mixed-pixel bias besides the noise (RayMatchSetting); it is part of seam_error_bound_m [m]. How much the
  /// yaw bound would grow is reported and not added: on eight passes it made the tube on its plate uncertain
  /// by 0.5-0.6 deg where it was 0.02-0.09 deg off (50 cells) [rad].
  double edge_shift_m = 0.0, edge_turn_rad = 0.0;
  /// With viewpoints: the sweep's passes fitted alone (pass_agreement.hpp), and by how much the two that
  /// disagree most put the seams farther apart than their 95 % bound allows [m] (and how far apart [m]).
  int passes_fitted = 0;
  double pass_excess_m = 0.0, pass_apart_m = 0.0;
  /// Where the cell's table is known (TablePlaneSetting::cell_top_z_m): the table the scan shows against it
  /// (table_plane.hpp), and whether that alone refused the pose: the LiDAR's mount is off, and sweeping
  /// again through it cannot help.
  bool table_known = false;
  TableDiscrepancy table;
  bool table_off = false;
  /// Where the prepared part came from: "off" (built, nothing kept), "read" (a file of an earlier run),
  /// "written" (built and kept for the next run), "not written: <why>" (built)
  std::string part_file = "off";
  double seconds = 0.0;
  std::vector<std::pair<std::string, double>>
      stage_seconds;  ///< table, model (waiting for the part, built beside the table), objects, search,
                      ///< refine, fit (the surface fit, the bounds), verdict
};

/// A part's mesh made ready for localize(): surface samples, which of them a scanner can see, the mesh for
/// rays, the footprint (tens of milliseconds for a part). To localize many scans of one part, prepare it
/// once; every answer is the one localize() gives with the mesh itself. One may be shared by several
/// localize() calls at once (a lookup grid inside it fills as it is asked, with the same answers whoever
/// fills it).
class PreparedPart {
 public:
  /// `in_background`: made ready on a thread of its own (the mesh copied), so that the caller can read the
  /// scan meanwhile; localize() finds the table first and then waits for it. An error in the mesh is thrown
  /// there.
  /// `keep_dir` (optional): a folder where prepared parts are kept between runs (part_model_file.hpp): the
  /// part is read from there when an earlier run of this program prepared it with the same setting, and
  /// written there when not. Any trouble with it (unwritable, damaged) only means the part is built.
  explicit PreparedPart(const Mesh& mesh, const LocalizeSetting& setting = {}, bool in_background = false,
                        const std::string& keep_dir = "");

  /// With a `keep_dir`: keeps the answers its nearest-sample grid has gathered for the next run, when they
  /// have grown since they were read (part_model_file.hpp). Returns "" or why they could not be kept. Call
  /// it when no localize() is using the part.
  std::string keep_lookups() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
  friend PoseEstimate localize(const std::vector<Vec3>&, const PreparedPart&, const LocalizeSetting&,
                               const std::vector<Vec3>&, const std::vector<Vec3>&);
};

/// Localizes `model` (part frame, resting on z = its lowest vertex) in `scan_base`. `seam_points` (part
/// frame, optional) are points along the part's weld seams, about 1 mm apart: two poses that map them onto
/// each other weld the same place, so they are not ambiguous even where the mesh itself is not symmetric (a
/// round tube on a square plate). `viewpoints_base` (optional, one per scan point) is where the sensor was
/// when it saw each point: it tells the two sides of a thin wall apart, which the points alone cannot under
/// range noise comparable to the wall's thickness.
PoseEstimate localize(const std::vector<Vec3>& scan_base, const Mesh& model,
                      const LocalizeSetting& setting = {}, const std::vector<Vec3>& seam_points = {},
                      const std::vector<Vec3>& viewpoints_base = {});

/// The same with the part prepared beforehand (with the same model spacing as `setting`'s; another throws
/// std::invalid_argument). The "model" stage is then the time to look it up, not to build it.
PoseEstimate localize(const std::vector<Vec3>& scan_base, const PreparedPart& part,
                      const LocalizeSetting& setting = {}, const std::vector<Vec3>& seam_points = {},
                      const std::vector<Vec3>& viewpoints_base = {});

}  // namespace weldtwin
