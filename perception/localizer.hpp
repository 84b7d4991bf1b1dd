// Finding a part in a base-frame cloud of a table scene, with figures that say how far to trust the answer.
// The part rests on the table: the table plane (cascaded RANSAC, refitted away from what stands on it) fixes
// roll, pitch and height and gives the range noise sigma, which sets every later threshold. The remaining
// (x, y, yaw) is searched globally by Hough voting of oriented wall points against the model — no initial
// guess, no region of interest — and the most promising peaks are refined by an (x, y, yaw) point-to-plane
// ICP that registers the scan onto the model with symmetric trimming: faces no scanner can see and samples
// near feature edges are left out. Where the cloud says where the sensor was for each point (a swept scan
// does), every ray is cast against the model at the current pose and matched with the face it meets — the
// choice depends on the ray, never on the range noise, so the two sides of a thin wall and the plate's low
// walls are told apart exactly. Without viewpoints, the less-seen side of thin walls is left out, matches are
// chosen by neighbourhood centroids, and walls too low to tell from the table are read from the height step
// across the outline. The
// verdict weighs coverage, fitness, free space (table seen where the part would stand), the walls' residual
// against the noise, and ambiguity between distinct poses (poses the part's own symmetry, or its seams, map
// onto each other are equal).
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry.hpp"
#include "perception/mesh_io.hpp"

namespace weldtwin {

struct LocalizeSetting {
  // Table.
  double reach_radius_m = 1.2;       ///< the table is sought within this distance of the base axis
  double table_threshold_m = 0.006;  ///< RANSAC inlier distance for the table plane
  double table_max_tilt_deg = 15.0;  ///< the table plane's normal is within this angle of +z
  int table_sample_points = 40000;   ///< points the table RANSAC looks at (evenly thinned)
  double min_table_area_m2 = 0.15;   ///< a plane seen over less area is a box top, not the table
  // Objects above the table.
  double min_height_m = 0.005;   ///< points at least this far above the table belong to objects
  double base_keepout_m = 0.12;  ///< points this close to the base axis are the robot's base
  double voxel_m = 0.002;        ///< voxel edge for the object points
  // Model.
  double model_spacing_m = 0.002;  ///< model surface sample spacing
  // Global search.
  int normal_neighbours = 24;  ///< points for each normal's PCA (Hough only)
  int vote_points = 1500;      ///< scan wall points that vote
  double vote_xy_m = 0.004;    ///< Hough bin size in x and y
  double vote_yaw_deg = 2.0;   ///< Hough bin size in yaw
  int hypotheses = 12;         ///< Hough peaks looked at
  int refined_hypotheses = 5;  ///< of those, the most promising refined coarsely
  int finalists = 3;           ///< coarse results refined fully
  // Refinement: (x, y, yaw) point-to-plane ICP, trimmed symmetrically at a multiple of the range noise.
  int point_to_point_iterations = 3;  ///< closed-form steps before the coarse point-to-plane ones
  int coarse_iterations = 12;
  int coarse_points = 2500;  ///< scan points used per coarse iteration (evenly thinned)
  int fine_iterations = 25;
  int icp_max_points = 12000;           ///< scan points used per ICP iteration (evenly thinned)
  double icp_start_distance_m = 0.012;  ///< correspondence cut-off at the first ICP iteration
  double noise_trim = 2.5;              ///< residuals beyond this many noise sigmas are not used
  int smoothing_neighbours = 8;         ///< neighbours whose centroid decides a point's match
  double edge_margin_sigmas = 0.5;      ///< model samples this close to a feature edge are not used
  double height_cut_sigmas = 3.0;       ///< scan points this close to the table are not used by ICP
  double min_noise_m = 0.0005;          ///< floor of the estimated range noise
  // Verdict.
  double min_coverage = 0.45;       ///< fraction of the model's visible samples with scan points nearby
  double min_fitness = 0.55;        ///< fraction of the scan points in the model's region that it explains
  double max_free_space = 0.02;     ///< fraction of the model's footprint where the table is seen
  double max_wall_residual = 0.58;  ///< median |residual| on the walls, in table noise sigmas (a different
                                    ///< shape fits the walls worse than the noise explains)
  double ambiguity_ratio = 0.85;    ///< a distinct pose scoring this close to the best is ambiguous
  int threads = 0;                  ///< hypotheses refined side by side (0: all cores)
  // Optional rough pose (T_base_part) from elsewhere: refined first, beside the peaks of the global search.
  bool use_initial_guess = false;
  Iso3 initial_guess = Iso3::Identity();
};

struct PoseEstimate {
  bool found = false;
  std::string reason;  ///< why not found: no table, no part, poor fit, ambiguous
  Iso3 T_base_part = Iso3::Identity();
  double fitness = 0.0, rmse_m = 0.0, coverage = 0.0;
  double free_space = 0.0;     ///< fraction of the footprint where the scan sees the table through the part
  double ambiguity = 0.0;      ///< score of the best distinct non-equivalent pose over the best's
  double noise_m = 0.0;        ///< range noise sigma estimated from the table
  double wall_residual = 0.0;  ///< median |residual| of the scan points on the model's walls, in noise sigmas
  bool converged = false;
  int iterations = 0;
  int inliers = 0;
  Eigen::Vector4d table_plane = Eigen::Vector4d::Zero();  ///< n.x + d = 0, n up, base frame
  int object_points = 0;                                  ///< points above the table after voxelisation
  bool rays_cast = false;  ///< refined by casting each point's ray from its viewpoint (the cloud had them)
  double seconds = 0.0;
  std::vector<std::pair<std::string, double>>
      stage_seconds;  ///< model, table, objects, search, refine, verdict
};

/// The table: cascaded RANSAC for near-horizontal planes; of those spread over at least min_table_area_m2
/// (box tops are not), the highest (the floor is lower), refined by least squares away from everything
/// standing on it. `noise_m` is the spread of the points about it (robust sigma). False if there is none.
bool find_table_plane(const std::vector<Vec3>& scan_base, const LocalizeSetting& setting,
                      Eigen::Vector4d& plane, double& noise_m);

/// Centroid of the points in each occupied cube of edge `leaf_m` (PCL's voxel grid).
std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double leaf_m);

/// The rotation about z and translation in x, y that best move `from` onto `to` (pairs, least squares,
/// closed form by SVD of the 2x2 cross-covariance). Returns the transform applied to `from`.
Iso3 planar_rigid_fit(const std::vector<Vec3>& from, const std::vector<Vec3>& to);

/// A part's mesh made ready for localize(): surface samples, which of them a scanner can see, the mesh for
/// rays, the footprint (tens of milliseconds for a part). To localize many scans of one part, prepare it
/// once; every answer is the one localize() gives with the mesh itself. One may be shared by several
/// localize() calls at once (a lookup grid inside it fills as it is asked, with the same answers whoever
/// fills it).
class PreparedPart {
 public:
  explicit PreparedPart(const Mesh& mesh, const LocalizeSetting& setting = {});

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
