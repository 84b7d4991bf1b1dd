#include "perception/localize/wall_side.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel_for.hpp"
#include "perception/localize/stats.hpp"

namespace weldtwin {
namespace {

// The largest distance between where two poses put any seam point (part frames of P and Q).
double seam_offset(const Iso3& P, const Iso3& Q, const std::vector<Vec3>& seams) {
  const Iso3 D = Q * P.inverse();  // a seam point at s under P is at D s under Q's frame
  double worst = 0.0;
  for (const Vec3& s : seams) worst = std::max(worst, (D * s - s).norm());
  return worst;
}

}  // namespace

WallSideResult decide_wall_side(const std::vector<ScanPoint>& icp_points, const PartModel& model,
                                const std::vector<Iso3>& starts, const std::vector<Vec3>& seams, double noise,
                                const SurfaceIcpSetting& surface, const PoseUncertaintySetting& unc,
                                const WallSideSetting& s, int threads) {
  WallSideResult out;
  // One set of points for every fit: those near any start (or a wall's thickness from it), so that the costs
  // compare.
  double shift = 0.0;
  for (const Eigen::Vector2d& d : model.wall_side_shifts) shift = std::max(shift, d.norm());
  std::vector<ScanPoint> pts;
  {
    std::vector<uint8_t> taken(icp_points.size(), 0);
    const double m = surface.box_margin_m + shift;
    for (size_t i = 0; i < icp_points.size(); ++i)
      for (const Iso3& P : starts) {
        const Vec3 p = P * icp_points[i].raw;
        if (p.x() < model.lo.x() - m || p.y() < model.lo.y() - m || p.x() > model.hi.x() + m ||
            p.y() > model.hi.y() + m || p.z() > model.hi.z() + m)
          continue;
        taken[i] = 1;
        break;
      }
    for (size_t i = 0; i < icp_points.size(); ++i)
      if (taken[i]) pts.push_back(icp_points[i]);
    pts = thinned(pts, static_cast<size_t>(surface.max_points));
  }
  if (starts.empty()) return out;
  // Every start fitted, and the first moved across each direction of the part's thin walls; then, from where
  // the best fit so far settled (a coarse start a couple of millimetres off may have been moved to the wrong
  // places), the moves across the walls again, round after round while that finds a better fit (a pose on
  // the wrong side of two walls at once comes back in two rounds). A move that starts within retry_m of an
  // earlier start, or where an earlier fit settled, is not made again.
  std::vector<Iso3> tried = starts;
  for (const Eigen::Vector2d& d : model.wall_side_shifts)
    tried.push_back(planar_pose(d.x(), d.y(), 0.0, 0.0) * starts.front());
  std::vector<SurfaceFit> fits(tried.size());
  parallel_for(fits.size(), threads,
               [&](size_t i) { fits[i] = surface_icp(pts, model, tried[i], noise, surface); });
  auto best_of = [&]() {
    size_t k = 0;
    for (size_t i = 1; i < fits.size(); ++i)
      if (fits[i].cost < fits[k].cost) k = i;
    return k;
  };
  size_t k = best_of();
  for (int round = 0; round < s.max_rounds && !model.wall_side_shifts.empty(); ++round) {
    std::vector<Iso3> from;
    for (const Eigen::Vector2d& d : model.wall_side_shifts) {
      const Iso3 P = planar_pose(d.x(), d.y(), 0.0, 0.0) * fits[k].P;
      bool again = false;
      for (const SurfaceFit& f : fits) again = again || seam_offset(P, f.P, seams) <= s.distinct_seam_m;
      for (const Iso3& T : tried) again = again || seam_offset(P, T, seams) <= s.retry_m;
      if (!again) from.push_back(P);
    }
    tried.insert(tried.end(), from.begin(), from.end());
    std::vector<SurfaceFit> more(from.size());
    parallel_for(more.size(), threads,
                 [&](size_t i) { more[i] = surface_icp(pts, model, from[i], noise, surface); });
    const double before = fits[k].cost;
    fits.insert(fits.end(), more.begin(), more.end());
    k = best_of();
    if (!(fits[k].cost < before)) break;
  }
  out.fits = static_cast<int>(fits.size());
  out.best = fits[k];
  out.uncertainty = pose_uncertainty(out.best.terms, unc);
  // The cost is in units of the table's noise variance; the residuals' own variance and the design effect
  // turn its differences into log-likelihood ratios.
  double scale = 1.0;
  if (out.uncertainty.ok && out.uncertainty.residual_sigma_m > 0.0)
    scale = std::pow(noise / out.uncertainty.residual_sigma_m, 2) / out.uncertainty.design_effect;
  out.margin_llr = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < fits.size(); ++i) {
    const double offset = seam_offset(out.best.P, fits[i].P, seams);
    if (i == k || offset <= s.distinct_seam_m) continue;
    const double llr = (fits[i].cost - out.best.cost) * scale;
    if (llr < out.margin_llr) {
      out.margin_llr = llr;
      out.rival_offset_m = offset;
      out.residual_margin_llr =
          (fits[i].cost - fits[i].view_nats - (out.best.cost - out.best.view_nats)) * scale;
    }
  }
  return out;
}

}  // namespace weldtwin
