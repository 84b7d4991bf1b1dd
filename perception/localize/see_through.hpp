// What the rays say about a pose, when the cloud carries viewpoints. A scan point the LiDAR saw well behind
// the model's first surface along its ray says the part is not there (the ray went through it): stronger than
// the table seen under the footprint, which cannot tell a tube lying on the table (its inner floor a wall's
// thickness up) from the table itself. And which of the model's samples the sweep's rays reached at all (a
// ray whose first surface of the model is that sample's, and that was not stopped short of it by something
// in front): what one short pass could have seen of the part, against which its coverage is judged.
//
// Where the rays went through the model is judged region by region as well as over all of it: a wrong part
// whose body stands on the real one may be crossed by few of the rays that cross its box (the rest meet
// the real part where the two agree), yet by nearly all of those that meet it where it stands alone (a
// tube tee's branch beside a standing tee, a square plate turned off the real one's corners). Rays that pass
// near a depth edge of the model are left out there: the beam straddles the edge and may report a range
// behind it (a mixed pixel).
#pragma once

#include <cstdint>
#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/ray_matching.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct SeeThroughSetting {
  double behind_sigmas = 3.0;   ///< a point this many noise sigmas behind the model's surface on its ray ...
  double min_behind_m = 0.005;  ///< ... and at least this far went through it [m]
  double box_margin_m = 0.01;   ///< rays crossing the model's box grown by this are looked at [m]
  int max_rays = 20000;         ///< at most this many of them (evenly thinned)
  /// A ray whose point lies behind the model's first surface on it, or at most this many noise sigmas (and
  /// at least reach_min_m) before it, reached that surface: the model samples within reach_radius_m of where
  /// it meets the surface are marked reached (those of a face turned towards the ray: not the other face of
  /// a thin wall). A ray stopped well short of the model by something in front of it did not.
  double reach_sigmas = 3.0;
  double reach_min_m = 0.004;     ///< [m]
  double reach_radius_m = 0.004;  ///< [m]
  int reach_neighbours = 8;       ///< model samples looked at around each hit
  /// The model's surface in cubes this wide (part frame) [m]: a cube where at least min_region_through of the
  /// rays that met the model there, away from its depth edges, went through it, and at least
  /// region_through_share of all that met it there, says the part is not there (right poses: at most 7 and
  /// 29 % over 640 one-pass cells; another part standing on the real one: 10-53 and 100 %)
  double region_m = 0.025;
  int min_region_through = 10;
  double region_through_share = 0.5;
};

struct SeeThrough {
  int rays = 0;     ///< rays crossing the model's box
  int through = 0;  ///< ... that went through the model
  /// Per model sample: a ray reached it (met the model's surface there, unobstructed before it). Empty when
  /// the rays are not known.
  std::vector<uint8_t> reached;
  double share() const { return rays ? static_cast<double>(through) / rays : 0.0; }
  /// The cube of the model's surface (see SeeThroughSetting::region_m) with the most rays through it away
  /// from its depth edges: how many, of how many that met the model there, and its centre (part frame).
  int region_through = 0, region_rays = 0;
  Vec3 region_at = Vec3::Zero();
  bool region_seen_through = false;  ///< ... at least min_region_through and region_through_share of them
};

/// The rays of `scene.ray_points` (points `scan_base`, viewpoints `viewpoints_base`) against the model at
/// pose P (table frame -> part frame); `edges` says which rays pass near a depth edge of the model (the fit's
/// own setting).
SeeThrough rays_through_model(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                              const std::vector<Vec3>& viewpoints_base, const PartModel& model, const Iso3& P,
                              const SeeThroughSetting& setting = {}, const RayMatchSetting& edges = {});

}  // namespace weldtwin
