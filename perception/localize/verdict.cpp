#include "perception/localize/verdict.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {
namespace {

// Whether the model maps onto itself under D (part frame): a symmetry, so poses D apart are the same weld.
bool self_similar(PartModel& model, const Iso3& D, const VerdictSetting& s) {
  double sum = 0.0;
  int n = 0;
  double d2 = 0.0;
  for (size_t k = 0; k < model.pts.size(); k += static_cast<size_t>(s.symmetry_stride)) {
    if (!model.visible[k]) continue;
    if (model.tree.nearest(D * model.pts[k], d2) < 0) continue;
    sum += std::sqrt(d2);
    ++n;
  }
  return n > 0 && sum / n < s.symmetry_m;
}

// Whether D (part frame to part frame) maps every seam point within same_seam_m of some seam point (they are
// about 1 mm apart).
bool same_seams(const std::vector<Vec3>& seam, const Iso3& D, const VerdictSetting& s) {
  if (seam.empty()) return false;
  for (const Vec3& p : seam) {
    const Vec3 q = D * p;
    double best = 1e9;
    for (const Vec3& r : seam) best = std::min(best, (q - r).squaredNorm());
    if (best > s.same_seam_m * s.same_seam_m) return false;
  }
  return true;
}

}  // namespace

double ambiguity(const Candidate& best, const std::vector<const Candidate*>& rivals, PartModel& model,
                 const std::vector<Vec3>& seam_points, const Iso3& lift, double max_free_space,
                 const VerdictSetting& s) {
  double out = 0.0;
  for (const Candidate* r : rivals) {
    if (r == &best || r->score.free_space > max_free_space) continue;
    const Iso3 D = best.P * r->P.inverse();  // part frame to part frame
    // The same pose found twice, or a shallower minimum next to it: not a rival.
    if (D.translation().norm() < s.same_pose_m &&
        Eigen::AngleAxisd(D.linear()).angle() < deg2rad(s.same_pose_deg))
      continue;
    if (self_similar(model, D, s)) continue;
    if (same_seams(seam_points, lift.inverse() * D * lift, s)) continue;
    out = std::max(out, r->score.support() / std::max(1e-9, best.score.support()));
  }
  return out;
}

std::string verdict_reason(const Score& best, double ambiguity, double max_free_space,
                           const VerdictSetting& s) {
  const double fitness = best.region ? static_cast<double>(best.inliers) / best.region : 0.0;
  if (best.free_space > max_free_space) return "the table is seen where the best match would stand";
  if (best.coverage < s.min_coverage) return "the best match covers too little of the model";
  if (fitness < s.min_fitness) return "the part fits the scan poorly";
  if (best.wall_residual > s.max_wall_residual)
    return "the part's walls fit the scan worse than the noise explains: a different part?";
  if (ambiguity >= s.ambiguity_ratio) return "ambiguous: a different pose fits almost as well";
  return "";
}

}  // namespace weldtwin
