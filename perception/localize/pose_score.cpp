#include "perception/localize/pose_score.hpp"

#include <cmath>

#include "perception/localize/stats.hpp"

namespace weldtwin {

Score score_pose(const ScenePoints& c, const Grid2& footprint, PartModel& m, const Iso3& P,
                 const PoseScoreSetting& s) {
  Score out;
  const std::vector<Vec3>& scan = c.objects;
  const NoiseLimits& lim = c.limits;
  double sum2 = 0.0;
  std::vector<double> wall;
  const double margin = s.box_margin_m, wall2 = s.wall_reach_m * s.wall_reach_m;
  for (const Vec3& q : scan) {
    if (q.z() < lim.height_cut_m) continue;
    const Vec3 p = P * q;
    if (p.x() < m.lo.x() - margin || p.y() < m.lo.y() - margin || p.x() > m.hi.x() + margin ||
        p.y() > m.hi.y() + margin || p.z() > m.hi.z() + s.above_top_m)
      continue;
    ++out.region;
    const int k = m.nearest(p);
    if (k < 0) continue;
    const Vec3 d = p - m.pts[static_cast<size_t>(k)];
    const double r = d.dot(m.nrm[static_cast<size_t>(k)]);
    if (std::abs(m.nrm[static_cast<size_t>(k)].z()) < s.wall_normal_z && m.visible[static_cast<size_t>(k)] &&
        d.squaredNorm() < wall2)
      wall.push_back(std::abs(r) / lim.noise_m);
    if (std::abs(r) < lim.inlier_m && d.squaredNorm() < 4 * lim.inlier_m * lim.inlier_m) {
      ++out.inliers;
      sum2 += r * r;
    }
  }
  out.rmse = out.inliers ? std::sqrt(sum2 / out.inliers) : 1.0;
  out.wall_residual = median(wall);
  out.coverage = coverage(c, m, P, {}, s);
  // Free space: the table seen where the part would rest on it, clearly below the part's lowest surface
  // there (cells averaged, so that single noisy points do not count).
  const Iso3 T = P.inverse();
  int cells = 0, through = 0;
  for (size_t i = 0; i < footprint.on.size(); ++i) {
    if (!footprint.on[i]) continue;
    ++cells;
    const Eigen::Vector2d xy = footprint.centre(static_cast<long>(i));
    const Vec3 q = T * Vec3(xy.x(), xy.y(), 0.0);
    const long j = c.low.index(q.x(), q.y());
    if (j < 0 || c.low_count[static_cast<size_t>(j)] == 0) continue;
    const double mean = c.low_sum[static_cast<size_t>(j)] / c.low_count[static_cast<size_t>(j)];
    through += mean < footprint.value[i] - s.free_space_sigmas * lim.noise_m;
  }
  out.free_space = cells ? static_cast<double>(through) / cells : 0.0;
  out.max_free = s.max_free_space;
  out.max_see_through = s.max_see_through_share;
  return out;
}

double coverage(const ScenePoints& c, const PartModel& m, const Iso3& P, const std::vector<uint8_t>& among,
                const PoseScoreSetting& s) {
  // Visible samples facing up or sideways, high enough to be told from the table, with a scan point near.
  const Iso3 T = P.inverse();
  const double reach = std::max(s.min_coverage_reach_m, s.coverage_sigmas * c.limits.noise_m);
  int seen = 0, total = 0;
  double d2 = 0.0;
  for (size_t k = 0; k < m.pts.size(); k += static_cast<size_t>(s.coverage_stride)) {
    if (!m.visible[k] || m.nrm[k].z() < s.coverage_min_normal_z || m.pts[k].z() < c.limits.height_cut_m)
      continue;
    if (!among.empty() && !among[k]) continue;
    ++total;
    if (c.tree.nearest_within(T * m.pts[k], reach, d2) >= 0) ++seen;
  }
  return total ? static_cast<double>(seen) / total : 0.0;
}

bool better_score(const Score& a, const Score& b) {
  const bool fa = a.allowed(), fb = b.allowed();
  if (fa != fb) return fa;
  return a.support() > b.support();
}

}  // namespace weldtwin
