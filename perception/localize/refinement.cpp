#include "perception/localize/refinement.hpp"

#include <algorithm>

#include "core/parallel_for.hpp"
#include "perception/localize/ray_matching.hpp"
#include "perception/localize/stats.hpp"

namespace weldtwin {

void look_with_rays(const RefineInput& in, Candidate& c, const PoseScoreSetting& score,
                    const SeeThroughSetting& see_through, const RayMatchSetting& edges) {
  // None may go through the part, and what they reached of it must be seen.
  const SeeThrough rays =
      rays_through_model(in.scene, in.scan_base, in.viewpoints_base, in.model, c.P, see_through, edges);
  c.score.see_through = rays.share();
  c.score.ray_count = rays.rays;
  c.score.through_count = rays.through;
  c.score.region_through = rays.region_through;
  c.score.region_rays = rays.region_rays;
  c.score.region_at = rays.region_at;
  c.score.region_seen_through = rays.region_seen_through;
  if (std::find(rays.reached.begin(), rays.reached.end(), 1) != rays.reached.end())
    c.score.reached_coverage = coverage(in.scene, in.model, c.P, rays.reached, score);
  c.rays_looked = true;
}

Candidate refine_with_rays(const RefineInput& in, const Candidate& c, const PlanarIcpSetting& icp,
                           const PoseScoreSetting& score, const SeeThroughSetting& see_through) {
  const std::vector<ScanPoint> near =
      thinned(rays_near_pose(in.scene, in.scan_base, in.viewpoints_base, in.model, c.P, icp.rays),
              static_cast<size_t>(icp.fine_points));
  const IcpResult f = planar_icp(near, in.scene, in.model, c.P, icp.fine_iterations, true, icp);
  Candidate out{f.P, f, score_pose(in.scene, in.footprint, in.model, f.P, score)};
  look_with_rays(in, out, score, see_through, icp.rays);
  return out;
}

Refinement refine_hypotheses(const RefineInput& in, const std::vector<Hypothesis>& hyps,
                             const PlanarIcpSetting& icp, const PoseScoreSetting& score,
                             const SeeThroughSetting& see_through, const RefineSetting& s, int threads) {
  const ScenePoints& scene = in.scene;
  PartModel& model = in.model;
  auto better = [&](const Candidate& a, const Candidate& b) { return better_score(a.score, b.score); };
  auto distinct_from = [&](const Candidate& r, const std::vector<Candidate>& others) {
    for (const Candidate& o : others) {
      const Iso3 D = o.P * r.P.inverse();
      if (D.translation().norm() < s.distinct_finalist_m &&
          Eigen::AngleAxisd(D.linear()).angle() < deg2rad(s.distinct_finalist_deg))
        return false;
    }
    return true;
  };
  Refinement out;
  std::vector<Candidate>& coarse = out.coarse;
  std::vector<Candidate>& refined = out.refined;
  const size_t batch = static_cast<size_t>(std::max(1, s.batch));
  for (size_t first = 0; first < hyps.size(); first += batch) {
    const size_t n = std::min(batch, hyps.size() - first);
    std::vector<Candidate> looked(n);
    parallel_for(n, threads, [&](size_t i) {
      const Hypothesis& h = hyps[first + i];
      const Iso3 P0 = planar_pose(h.x, h.y, 0.0, h.yaw).inverse();
      const IcpResult r = planar_icp(
          thinned(points_near_pose(scene.icp_points, model, P0, icp), static_cast<size_t>(icp.coarse_points)),
          scene, model, P0, icp.coarse_iterations, false, icp);
      looked[i] = {r.P, r, score_pose(scene, in.footprint, model, r.P, score)};
    });
    // The best few distinct of this batch (and distinct from the finalists of earlier ones).
    std::sort(looked.begin(), looked.end(), better);
    std::vector<Candidate> chosen;
    for (const Candidate& r : looked)
      if (static_cast<int>(chosen.size()) < s.finalists && distinct_from(r, chosen) &&
          distinct_from(r, refined))
        chosen.push_back(r);
    coarse.insert(coarse.end(), looked.begin(), looked.end());
    // With rays, the finalists are refined by casting them; without, the surface fit refines them.
    std::vector<Candidate> fine(chosen.size());
    parallel_for(chosen.size(), threads, [&](size_t i) {
      if (scene.ray_points.empty()) {
        fine[i] = chosen[i];
        return;
      }
      fine[i] = refine_with_rays(in, chosen[i], icp, score, see_through);
    });
    refined.insert(refined.end(), fine.begin(), fine.end());
    if (std::any_of(refined.begin(), refined.end(), [](const Candidate& c) { return c.score.allowed(); }))
      break;
  }
  std::sort(refined.begin(), refined.end(), better);
  return out;
}

}  // namespace weldtwin
