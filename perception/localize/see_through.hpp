// What the rays say about a pose, when the cloud carries viewpoints. A scan point the LiDAR saw well behind
// the model's first surface along its ray says the part is not there (the ray went through it): stronger than
// the table seen under the footprint, which cannot tell a tube lying on the table (its inner floor a wall's
// thickness up) from the table itself. And which of the model's samples the sweep's rays reached at all (a
// ray whose first surface of the model is that sample's, and that was not stopped short of it by something
// in front): what one short pass could have seen of the part, against which its coverage is judged.
#pragma once

#include <cstdint>
#include <vector>

#include "perception/localize/part_model.hpp"
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
};

struct SeeThrough {
  int rays = 0;     ///< rays crossing the model's box
  int through = 0;  ///< ... that went through the model
  /// Per model sample: a ray reached it (met the model's surface there, unobstructed before it). Empty when
  /// the rays are not known.
  std::vector<uint8_t> reached;
  double share() const { return rays ? static_cast<double>(through) / rays : 0.0; }
};

/// The rays of `scene.ray_points` (points `scan_base`, viewpoints `viewpoints_base`) against the model at
/// pose P (table frame -> part frame).
SeeThrough rays_through_model(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                              const std::vector<Vec3>& viewpoints_base, const PartModel& model, const Iso3& P,
                              const SeeThroughSetting& setting = {});

}  // namespace weldtwin
