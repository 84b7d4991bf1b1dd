// Matching by rays, for clouds that carry every point's viewpoint: each point's ray, cast from where the
// LiDAR was against the model at the current pose, is matched with the face it meets. Which face a point
// belongs to then depends on where the sensor looked, never on where the range noise threw the point, so
// the two sides of a thin wall (a 3.2 mm tube wall under 2 mm noise) and a plate's low walls next to the
// table are told apart exactly.
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct RayMatchSetting {
  /// Rays near a depth edge of the model: the LiDAR's beam, a few millimetres wide at the part and its
  /// samples about as far apart, straddles the edge there and may report a range between the two surfaces
  /// (a mixed pixel), behind the near one or before the far one. A ray is near one when a ray beside it,
  /// this far off at the range it meets the model, meets the model more than depth_jump_m nearer or
  /// farther, or misses it [m]. Their residuals carry a bias besides the range noise, the same along the
  /// edge (ResidualTerm::unseen_sigma_m): a blend is a point of neither surface, so its residual against the
  /// face is whatever the trim lets through, half of it on average, and this share of the samples at an edge
  /// blend. (Scaled by the ray's incidence on the face instead, as if the blend only slid along the ray, it
  /// left all three poses accepted 1.3-2.4 mm off in 300 one-pass cells: in the first, with no mixed pixels
  /// at all, the fit cannot tell the tee's place along its run, so the blends alone had decided it.)
  double beam_offset_m = 0.004;
  double depth_jump_m = 0.01;      ///< [m]
  double mixed_pixel_share = 0.5;  ///< samples at a depth edge that report a blend (pessimistic: half)
  bool mark_depth_edges = false;   ///< mark the rays near depth edges (decided where the fit starts)
  double ray_window_m = 0.02;      ///< a ray meeting the model this much before or beyond its range meets
                                   ///< something else [m]
  double level_normal_z = 0.95;    ///< faces this level say nothing of (x, y, yaw)
  /// A ray meeting its face more obliquely than this does not place it: the LiDAR's returns fade away at
  /// such incidence, and what is seen there is mostly a blend at the face's edge, the ray that passed by the
  /// edge up to a sample spacing off reporting a range between the two surfaces. Along a long edge seen
  /// from one side those blends all lean the same way and imitate the face moved by up to that spacing (the
  /// tube tee's two long top edges, swept from its end: the tee placed 2.4-2.8 mm across its tube, the
  /// bound under 1 mm) [deg]
  double max_incidence_deg = 80.0;
  double outline_band_m = 0.008;  ///< table-level points this close to the footprint's outline take part [m]
  double box_margin_m = 0.015;    ///< rays whose points lie this far beyond the model's box are not cast [m]
  double deep_level_m = 0.004;    ///< points this close to a level face, deep inside it, are not cast [m]
  double deep_edge_sigmas = 3.0;  ///< deep inside: farther from its edges than this many noise sigmas ...
  double deep_edge_m = 0.002;     ///< ... plus this [m]
};

/// The rays that may meet a face that can move (x, y, yaw) at pose P (table frame -> part frame):
/// table-level points near the footprint's outline (the plate's walls), and the rest unless deep inside a
/// level face (where no noise can carry a point off it).
std::vector<ScanPoint> rays_near_pose(const ScenePoints& scene, const std::vector<Vec3>& scan_base,
                                      const std::vector<Vec3>& viewpoints_base, PartModel& model,
                                      const Iso3& P, const RayMatchSetting& setting = {});

/// Per ray of `rays` (with their origins, table frame): whether it passes near a depth edge of the model at
/// pose P (see RayMatchSetting::beam_offset_m).
std::vector<uint8_t> rays_near_depth_edges(const std::vector<ScanPoint>& rays, const PartModel& model,
                                           const Iso3& P, const RayMatchSetting& setting = {});

/// Whether the ray from `origin` along unit `dir` (part frame), whose point lies `range` away and which
/// meets the model `t` along (infinite: not within range + ray_window_m), passes near a depth edge of it.
bool ray_near_depth_edge(const PartModel& model, const Vec3& origin, const Vec3& dir, double t, double range,
                         const RayMatchSetting& setting);

/// face[i]: the model sample where ray i meets the model at pose P, or -1 where it meets something else,
/// a level face, a face seen from behind, or lands near a feature edge or the table (within edge_margin_m),
/// where which face a ray meets changes with the pose itself.
void match_rays(const std::vector<ScanPoint>& rays, PartModel& model, const Iso3& P, double edge_margin_m,
                const RayMatchSetting& setting, std::vector<int>& face);

}  // namespace weldtwin
