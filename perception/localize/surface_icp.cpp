#include "perception/localize/surface_icp.hpp"

#include <algorithm>
#include <cmath>

#include "perception/localize/stats.hpp"

namespace weldtwin {
namespace {

constexpr double kTukeyNorm = 6.0;       // rho(r) = c^2/6 (1 - (1 - (r/c)^2)^3), capped at c^2/6
constexpr double kMinDirection = 1e-7;   // a centroid closer than this to the surface takes the face normal
constexpr double kWallDirectionZ = 0.5;  // a match whose direction is this level is on a wall
constexpr double kLevelNormalZ = 0.95;   // ... this steep, on a level face

// The model sample of the face at `at` (outward `normal`): the nearest sample, if it is of the same face
// (its normal agrees), else -1.
int face_sample(const PartModel& m, const Vec3& at, const Vec3& normal) {
  constexpr double kSameFace = 0.5;     // normals' cosine
  constexpr double kSampleReach = 2.0;  // a point on the mesh has a sample this many spacings away, mostly
  double d2 = 0.0;
  const int k = m.tree.nearest_likely_within(at, kSampleReach * m.spacing_m, d2);
  return k >= 0 && m.nrm[static_cast<size_t>(k)].dot(normal) > kSameFace ? k : -1;
}

double kernel_m(double noise, const SurfaceIcpSetting& s) {
  return std::max(s.min_kernel_m, s.kernel_sigmas * noise);
}

// The residuals at P: for each point, its match on the mesh, the direction from the match to the centroid,
// the raw point's residual along it, Tukey's weight and the Jacobian w.r.t. (yaw, x, y) of the part.
double residuals(const std::vector<ScanPoint>& pts, const PartModel& m, const Iso3& P, double c,
                 std::vector<ResidualTerm>& terms, int& inliers, std::vector<double>* wall = nullptr,
                 std::vector<double>* level = nullptr, std::vector<double>* wall_r = nullptr,
                 std::vector<int>* samples = nullptr, int* unexplained = nullptr) {
  terms.clear();
  inliers = 0;
  double cost = 0.0;
  const double cap = c * c / kTukeyNorm;
  Vec3 at, normal;
  for (const ScanPoint& sp : pts) {
    const Vec3 x = P * sp.raw, xs = P * sp.smooth;
    if (!m.surface->closest(xs, 2 * c, at, normal)) {
      cost += cap;
      if (unexplained) ++*unexplained;
      continue;
    }
    const Vec3 d = xs - at;
    const double dn = d.norm();
    const Vec3 u = dn > kMinDirection ? Vec3(d / dn) : normal;
    if (wall && std::abs(u.z()) < kWallDirectionZ) wall->push_back(dn);
    if (level && std::abs(normal.z()) > kLevelNormalZ && std::abs(u.z()) > kLevelNormalZ)
      level->push_back(d.z());
    const double r = u.dot(x - at);
    if (std::abs(r) >= c) {
      cost += cap;
      if (unexplained) ++*unexplained;
      continue;
    }
    if (wall_r && std::abs(u.z()) < kWallDirectionZ) wall_r->push_back(std::abs(r));
    const double q = 1.0 - (r / c) * (r / c);
    cost += cap * (1.0 - q * q * q);
    if (samples) samples->push_back(face_sample(m, at, normal));
    ResidualTerm t;
    t.J = Vec3(x.x() * u.y() - x.y() * u.x(), u.x(), u.y());
    t.r = r;
    t.w = q * q;
    t.at = at;
    terms.push_back(t);
    ++inliers;
  }
  return cost;
}

}  // namespace

std::vector<ScanPoint> surface_points(const std::vector<ScanPoint>& from, const PartModel& model,
                                      const Iso3& P, double extra_margin_m, const SurfaceIcpSetting& s) {
  std::vector<ScanPoint> near;
  const double m = s.box_margin_m + extra_margin_m;
  for (const ScanPoint& sp : from) {
    const Vec3 p = P * sp.raw;
    if (p.x() < model.lo.x() - m || p.y() < model.lo.y() - m || p.x() > model.hi.x() + m ||
        p.y() > model.hi.y() + m || p.z() > model.hi.z() + m)
      continue;
    near.push_back(sp);
  }
  return thinned(near, static_cast<size_t>(s.max_points));
}

SurfaceFit surface_cost(const std::vector<ScanPoint>& pts, const PartModel& m, const Iso3& P, double noise,
                        const SurfaceIcpSetting& s) {
  SurfaceFit out;
  out.P = P;
  std::vector<double> wall, level, wall_r;
  std::vector<int> samples;
  int unexplained = 0;
  const bool prior = s.view.weight > 0;
  out.cost = residuals(pts, m, P, kernel_m(noise, s), out.terms, out.inliers, &wall, &level, &wall_r,
                       prior ? &samples : nullptr, prior ? &unexplained : nullptr) /
             (noise * noise);
  out.view_nats = prior ? view_prior_nats(m, samples, unexplained, s.view) : 0.0;
  out.cost += out.view_nats;
  out.wall_offset_m = median(wall);
  out.level_offset_m = median(level);
  out.wall_sigma_m = kMadToSigma * median(wall_r);
  return out;
}

SurfaceFit surface_icp(const std::vector<ScanPoint>& pts, const PartModel& m, Iso3 P, double noise,
                       const SurfaceIcpSetting& s) {
  SurfaceFit out;
  const double c = kernel_m(noise, s);
  std::vector<ResidualTerm> terms;
  int inliers = 0;
  // Steps on every coarse_stride-th point while they are long (the way from a start millimetres off), then
  // on every point to the end: the same end, in a fraction of the time.
  std::vector<ScanPoint> few;
  for (size_t i = 0; i < pts.size(); i += static_cast<size_t>(std::max(1, s.coarse_stride)))
    few.push_back(pts[i]);
  // One Gauss-Newton step on `use`: its length (yaw times yaw_lever_m + translation), or -1 with too few
  // residuals.
  auto step = [&](const std::vector<ScanPoint>& use) {
    residuals(use, m, P, c, terms, inliers);
    if (terms.size() < 3) return -1.0;
    Mat3 A = s.damping * Mat3::Identity();
    Vec3 b = Vec3::Zero();
    for (const ResidualTerm& t : terms) {
      A += t.w * t.J * t.J.transpose();
      b -= t.w * t.r * t.J;
    }
    const Vec3 xi = A.ldlt().solve(b);
    P = planar_pose(xi.y(), xi.z(), 0.0, xi.x()) * P;
    return std::abs(xi.x()) * s.yaw_lever_m + xi.tail<2>().norm();
  };
  for (int it = 0; s.coarse_stride > 1 && it < s.coarse_iterations; ++it) {
    const double d = step(few);
    if (d < s.coarse_step_m) break;  // (or too few residuals: the fine steps say so)
  }
  for (int it = 0; it < s.iterations; ++it) {
    const double d = step(pts);
    out.iterations = it + 1;
    if (d < 0.0) break;
    if (d < s.converged_step_m) {
      out.converged = true;
      break;
    }
  }
  out.P = orthonormalized(P);
  const SurfaceFit at = surface_cost(pts, m, out.P, noise, s);
  out.cost = at.cost;
  out.view_nats = at.view_nats;
  out.inliers = at.inliers;
  out.terms = at.terms;
  out.wall_offset_m = at.wall_offset_m;
  out.level_offset_m = at.level_offset_m;
  out.wall_sigma_m = at.wall_sigma_m;
  return out;
}

}  // namespace weldtwin
