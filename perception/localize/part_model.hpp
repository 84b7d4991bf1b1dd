// Stage 0 of the localizer: a part's mesh made ready to be sought (PreparedPart holds one). Surface samples
// with outward normals, which of them a scanner above the table can see at all (and from how many of the
// test directions), how thick the material behind each is, how far each is from a feature edge, the wall
// samples by height for the Hough vote, the footprint on the table and its outline, and the mesh itself for
// rays. Everything is in the part's resting frame: the mesh lifted so that its lowest vertex is at z = 0.
#pragma once

#include <memory>
#include <vector>

#include "perception/localize/brick_slots.hpp"
#include "perception/localize/closest_grid.hpp"
#include "perception/localize/grid2.hpp"
#include "perception/localize/point_tree.hpp"
#include "perception/localize/view_prior.hpp"
#include "perception/mesh_io.hpp"
#include "perception/mesh_rays.hpp"

namespace weldtwin {

struct PartModelSetting {
  double spacing_m = 0.002;          ///< surface sample spacing [m]
  double min_normal_z = -0.7;        ///< faces pointing further down (the underside) are not sampled
  double thickness_probe_m = 0.05;   ///< how far behind and in front of a face the next surface is sought [m]
  double sharp_edge_deg = 30.0;      ///< faces meeting at more than this make a feature edge [deg]
  double edge_point_step_m = 0.001;  ///< feature edges as points this far apart [m]
  /// A sample's distance to the nearest feature edge is measured up to this; beyond, it is "far" (1 m). The
  /// stages ask whether a sample lies within half a noise sigma of an edge (planar ICP) or farther than 3
  /// sigmas + 2 mm (rays): exact for range noise up to 16 mm [m]
  double edge_reach_m = 0.05;
  double height_bin_m = 0.002;         ///< wall samples binned by height for the Hough vote [m]
  double footprint_cell_m = 0.002;     ///< footprint cell [m]
  double footprint_margin_m = 0.004;   ///< the footprint grid reaches this far beyond the samples [m]
  double outline_step_m = 0.001;       ///< outline samples this far apart [m]
  double outline_corner_m = 0.004;     ///< ... and this far from the outline's corners [m]
  double outline_inside_m = 0.003;     ///< the part's height at an outline sample is read this far inside [m]
  double lookup_cell_m = 0.001;        ///< cell of the lazily filled nearest-sample grid [m]
  double lookup_margin_m = 0.015;      ///< the grid reaches this far beyond the samples [m]
  double thin_wall_max_m = 0.012;      ///< walls thinner than this can be mistaken for their other side [m]
  double thin_wall_min_share = 0.05;   ///< ... when at least this share of the wall samples is that thin
  int wall_directions = 4;             ///< at most this many directions across thin walls are tried
  double wall_direction_gap_deg = 40;  ///< ... at least this far apart [deg]
  /// Faces continued past their convex edges by these distances (see part_extent.hpp) [m]
  std::vector<double> beyond_m{0.006, 0.010, 0.015, 0.020};
  double beyond_step_m = 0.002;         ///< ... every this far along the edge [m]
  double beyond_clearance_share = 0.7;  ///< ... where the part is at least this share of that away
  /// A wall continued up past a top edge into open air (nothing of the part above) is judged edge by edge
  /// (part_extent.hpp): continued at least this steeply (the z of its unit direction) [share]
  double beyond_up_min_z = 0.9;
  ClosestGridSetting closest;  ///< the surface fit's nearest points (closest_grid.hpp)
};

struct PartModel {
  std::vector<Vec3> pts, nrm;       ///< every face but the underside
  std::vector<uint8_t> visible;     ///< seen from outside (a scanner above the table can see it at all)
  std::vector<uint8_t> view_score;  ///< how many of the test directions see it (more: seen more often)
  std::vector<uint64_t> view_mask;  ///< which of the directions above see it (view_prior.hpp)
  std::array<double, kViewDirections> view_total{};  ///< view_totals of the samples (not stored in files)
  std::vector<float> half_thickness, edge_distance;  ///< [m] (edge_distance: 1 m beyond edge_reach_m)
  PointTree tree;
  std::unique_ptr<MeshRays> rays;             ///< the mesh itself, resting on z = 0
  std::unique_ptr<ClosestGrid> surface;       ///< its nearest points, the same answers as rays->closest
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  ///< bounding box of the samples
  double radius = 0.0, height = 0.0;          ///< [m]
  double spacing_m = 0.002;                   ///< the samples' spacing [m]
  double height_bin_m = 0.002;
  std::vector<std::vector<int>> walls_by_height;  ///< visible wall samples (every third) per height bin
  Grid2 footprint;                                ///< where the part rests on the table (value: lowest top)
  struct OutlineSample {
    Eigen::Vector2d at, out;  ///< on the footprint's outline, and the outward normal there
    double top = 0.0;         ///< height of the part just inside [m]
  };
  std::vector<OutlineSample> outline;  ///< every outline step, away from the outline's corners
  double thin_wall_m = 0.0;            ///< median thickness of the thin walls (0: none) [m]
  /// Moves of the part (its frame, x and y) by one thin wall's thickness across its walls: where a scan
  /// without viewpoints may fit the other side of every wall as well as the right one.
  std::vector<Eigen::Vector2d> wall_side_shifts;
  std::vector<Vec3> beyond;        ///< the faces continued past their convex edges, into free air
  std::vector<float> beyond_dist;  ///< ... and how far past the edge each sample is [m]
  /// ... and, for a wall continued up into open air, which wall past which straight edge: 2 x the edge's
  /// line + its side (one edge of the part may be several edges of its mesh; -1: not such a wall) ...
  std::vector<int> beyond_line;
  std::vector<float> beyond_line_length;  ///< ... and each such line's length [m]

  /// The sample nearest p, or -1 outside the lookup grid or farther than its margin (lookup_margin_m) from
  /// every sample. Answers come from a lazily filled grid (each slot holds the sample nearest its centre):
  /// ICP asks about the same places again and again. Safe to call from
  /// several threads: a slot is filled with the same answer by whoever gets there first.
  int nearest(const Vec3& p);

  double cache_cell = 0.001, cache_margin = 0.015;
  Vec3 cache_origin = Vec3::Zero();
  int cx = 0, cy = 0, cz = 0;
  /// The grid's slots: 0 not asked yet, else the answer + 2 (the grid spans tens of megabytes, ICP asks
  /// about a thin shell of it: brick_slots.hpp).
  BrickSlots<int> cache;
};

/// `mesh` lifted by -min_z and its faces turned outwards: the frame the model is built in.
Mesh resting_mesh(const Mesh& mesh, double min_z);

/// What the model's questions are answered by: the mesh for rays (made from `rest` when the model has none),
/// the samples' tree and the lookup grids (empty until asked). Needs the samples and their box.
void make_lookups(const Mesh& rest, const PartModelSetting& setting, PartModel& model);

/// Builds the model of `mesh` lifted by -min_z (faces turned outwards first: a CAD file's winding is not to
/// be trusted), on `threads` threads (0: all cores).
void build_part_model(const Mesh& mesh, double min_z, const PartModelSetting& setting, int threads,
                      PartModel& model);

/// The same for a mesh already lifted and turned outwards (resting_mesh).
void build_part_model_at_rest(const Mesh& rest, const PartModelSetting& setting, int threads,
                              PartModel& model);

}  // namespace weldtwin
