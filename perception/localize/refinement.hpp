// The refinement of the search's peaks: in batches, most promising first, every peak of a batch by a coarse
// planar ICP and the best few distinct of them fully (with viewpoints, by casting the rays); the next batch
// only while no finalist so far is allowed by the scan. A short sweep sees little of the part, and its peaks
// may be lower than those of clamps and clutter.
#pragma once

#include <vector>

#include "perception/localize/grid2.hpp"
#include "perception/localize/part_model.hpp"
#include "perception/localize/planar_icp.hpp"
#include "perception/localize/pose_score.hpp"
#include "perception/localize/pose_search.hpp"
#include "perception/localize/scene_points.hpp"
#include "perception/localize/see_through.hpp"
#include "perception/localize/verdict.hpp"

namespace weldtwin {

struct RefineSetting {
  int batch = 5;                       ///< peaks refined coarsely at a time
  int finalists = 3;                   ///< coarse results of a batch refined fully
  double distinct_finalist_m = 0.004;  ///< finalists closer than this ... [m]
  double distinct_finalist_deg = 2.0;  ///< ... and this are one [deg]
};

/// What the stages that follow weigh: every peak's coarse fit, and the finalists, best first.
struct Refinement {
  std::vector<Candidate> coarse, refined;
};

/// Everything the refinement and the verdict read of the scan and the part (table frame).
struct RefineInput {
  const ScenePoints& scene;
  const std::vector<Vec3>& scan_base;        ///< the cloud as given, base frame
  const std::vector<Vec3>& viewpoints_base;  ///< each point's viewpoint, or none
  PartModel& model;
  const Grid2& footprint;  ///< where the part rests, eroded by the noise
};

/// The peaks refined (see above), `threads` of them side by side (0: all cores).
Refinement refine_hypotheses(const RefineInput& in, const std::vector<Hypothesis>& hypotheses,
                             const PlanarIcpSetting& icp, const PoseScoreSetting& score,
                             const SeeThroughSetting& see_through, const RefineSetting& refine, int threads);

/// A candidate refined by casting the rays near it (the fine fit) and scored, rays looked at.
Candidate refine_with_rays(const RefineInput& in, const Candidate& c, const PlanarIcpSetting& icp,
                           const PoseScoreSetting& score, const SeeThroughSetting& see_through);

/// What the rays say of a candidate: the share of them that go through it, and what they reached of it that
/// the scan shows (Candidate::rays_looked).
void look_with_rays(const RefineInput& in, Candidate& c, const PoseScoreSetting& score,
                    const SeeThroughSetting& see_through, const RayMatchSetting& edges);

}  // namespace weldtwin
