// Whether the scan goes on beyond the model's edges. Where two faces of the part meet at a convex edge, each
// face continued past the edge runs into free air: the scan of the right part has nothing there, while a
// part that is taller, wider or longer than the model (a different part that shares the model's welds, or
// one that differs from its CAD) shows its surface going on. Samples of those continuations are made with
// the part model; a pose is checked by counting the ones with scan points on them: the longest stretch of
// them together, and, edge by edge, the share of a wall continued up past a top edge into open air (a
// taller part shows along the whole edge, where a clamp's arm crosses a stretch of it).
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct PartExtentSetting {
  double reach_sigmas = 2.0;   ///< a sample has scan points on it within this many noise sigmas ...
  double min_reach_m = 0.003;  ///< ... and at least within this [m]
  double link_m = 0.006;       ///< supported samples this close are one group [m]
  double spill_sigmas = 3.0;   ///< samples nearer the edge than the reach and this many sigmas are
                               ///< not used (noise spills points past an edge along grazing rays)
  /// A wall continued up past one straight top edge is judged alone when the edge is at least this long (a
  /// round rim's facets are not) ...
  double min_line_m = 0.03;
  int min_line_samples = 10;  ///< ... and at least this many of its samples are high enough to count
};

/// Samples of the part's faces continued past their convex edges (`setting.beyond_*`), in the resting frame
/// of `rest`, whose model is `model` (its samples and rays). Fills `model.beyond` and the fields after it.
void beyond_edge_samples(const Mesh& rest, PartModel& model, const PartModelSetting& setting);

struct PartExtent {
  int samples = 0;    ///< continuation samples high enough above the table to be told from it
  int supported = 0;  ///< ... with scan points on them
  /// The largest group of supported samples (linked within link_m): its box's diagonal and centre (resting
  /// frame). A clamp or a few stray returns make small groups; a part larger than its model makes long ones.
  double extent_m = 0.0;
  Vec3 centre = Vec3::Zero();
  /// The one wall continued up past one straight top edge into open air (setting.min_line_*) the scan
  /// supports most: the share of its samples with scan points on them, the edge's length [m] and the
  /// supported samples' centre (resting frame). A clamp's arm over an edge covers a stretch of it; a taller
  /// part, its whole length.
  double line_share = 0.0;
  double line_length_m = 0.0;
  Vec3 line_centre = Vec3::Zero();
  double share() const { return samples ? static_cast<double>(supported) / samples : 0.0; }
};

/// How many of `model.beyond` the scan supports at pose P (table frame -> part frame).
PartExtent scan_beyond_model(const ScenePoints& scene, const PartModel& model, const Iso3& P,
                             const PartExtentSetting& setting = {});

}  // namespace weldtwin
