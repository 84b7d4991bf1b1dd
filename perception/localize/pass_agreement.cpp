#include "perception/localize/pass_agreement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "perception/localize/stats.hpp"

namespace weldtwin {

PassAgreement pass_agreement(const std::vector<ScanPoint>& rays, const ScenePoints& scene, PartModel& model,
                             const Iso3& P, const std::vector<Vec3>& seams, const PlanarIcpSetting& icp,
                             const PoseUncertaintySetting& uncertainty, const PassAgreementSetting& s) {
  PassAgreement out;
  if (seams.empty()) return out;
  // The passes: runs of rays whose sensor moved little from one to the next.
  std::vector<std::vector<ScanPoint>> passes(1);
  for (size_t i = 0; i < rays.size(); ++i) {
    if (i > 0 && (rays[i].origin - rays[i - 1].origin).norm() > s.pass_jump_m) passes.emplace_back();
    passes.back().push_back(rays[i]);
  }
  // Each one's own fit, from the whole cloud's pose, its rays near depth edges marked as the whole fit's are.
  PlanarIcpSetting marked = icp;
  marked.rays.mark_depth_edges = true;
  marked.start_distance_m = 0.0;  // matches within the trim from the first step: a pass stays by the pose
  struct Fitted {
    Iso3 P;
    Mat3 covariance;
  };
  std::vector<Fitted> fitted;
  for (const std::vector<ScanPoint>& pass : passes) {
    if (pass.size() < static_cast<size_t>(s.min_rays)) continue;
    const IcpResult f = planar_icp(thinned(pass, static_cast<size_t>(s.max_rays)), scene, model, P,
                                   s.iterations, true, marked);
    const PoseUncertainty u = pose_uncertainty(f.terms, uncertainty);
    // A pass that alone cannot tell the part's turn (one that saw a round tube and no edge to turn it by),
    // or whose fit turned far from the pose (into another minimum: a square plate turned a quarter), is not
    // compared: where the covariance, taken at the pose, no longer describes it.
    const Iso3 moved = f.P * P.inverse();
    const double turned = std::abs(std::atan2(moved.linear()(1, 0), moved.linear()(0, 0)));
    if (!u.ok || f.terms.size() < static_cast<size_t>(icp.min_correspondences) ||
        !(std::sqrt(u.covariance(0, 0)) <= deg2rad(s.max_pass_turn_sd_deg)) ||
        !(turned <= deg2rad(s.max_pass_turn_deg)))
      continue;
    fitted.push_back({f.P, u.covariance});
  }
  out.passes = static_cast<int>(fitted.size());
  // Every two: how far apart they put each seam point, less what their uncertainties together allow along
  // that direction (independent passes: the covariances add; the same 95 % scale as the seam bound's). A
  // pass's fit may be loose one way (along a tube seen from one side) and tight another: the disagreement
  // counts where it is measured.
  const double scale = std::sqrt(confidence_scale2(std::numeric_limits<double>::infinity(), uncertainty));
  for (size_t a = 0; a < fitted.size(); ++a)
    for (size_t b = a + 1; b < fitted.size(); ++b) {
      const Iso3 D = fitted[a].P * fitted[b].P.inverse();  // part frame to part frame
      const Mat3 C = fitted[a].covariance + fitted[b].covariance;
      for (const Vec3& p : seams) {
        const Eigen::Vector2d v = (D * p - p).head<2>();
        const double apart = v.norm();
        if (apart <= 0.0) continue;
        const Eigen::Matrix<double, 2, 3> J = planar_move_jacobian(p);
        const Eigen::Vector2d along = v / apart;
        const double sd = std::sqrt(along.dot(J * C * J.transpose() * along));
        if (apart - scale * sd > out.excess_m) {
          out.excess_m = apart - scale * sd;
          out.apart_m = apart;
        }
      }
    }
  return out;
}

}  // namespace weldtwin
