// Free space along the rays, when the cloud carries viewpoints: a scan point the LiDAR saw well behind the
// model's first surface along its ray says the part is not there (the ray went through it). Stronger than the
// table seen under the footprint, which cannot tell a tube lying on the table (its inner floor a wall's
// thickness up) from the table itself.
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct SeeThroughSetting {
  double behind_sigmas = 3.0;   ///< a point this many noise sigmas behind the model's surface on its ray ...
  double min_behind_m = 0.005;  ///< ... and at least this far went through it [m]
  double box_margin_m = 0.01;   ///< rays crossing the model's box grown by this are looked at [m]
  int max_rays = 20000;         ///< at most this many of them (evenly thinned)
};

struct SeeThrough {
  int rays = 0;     ///< rays crossing the model's box
  int through = 0;  ///< ... that went through the model
  double share() const { return rays ? static_cast<double>(through) / rays : 0.0; }
};

/// The rays of `scene.ray_points` (points `scan_base`, viewpoints `viewpoints_base`) against the model at
/// pose P (table frame -> part frame).
SeeThrough rays_through_model(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                              const std::vector<Vec3>& viewpoints_base, const PartModel& model, const Iso3& P,
                              const SeeThroughSetting& setting = {});

}  // namespace weldtwin
