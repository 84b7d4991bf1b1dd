#include "perception/localize/planar_icp.hpp"

#include <algorithm>
#include <cmath>

#include "perception/localize/planar_fit.hpp"

namespace weldtwin {
namespace {

constexpr double kDamping = 1e-9;       // added to the normal equations' diagonal
constexpr int kMinPointPairs = 20;      // a closed-form step from fewer pairs is not taken
constexpr double kOppositeFace = -0.5;  // the face behind a thin wall faces the other way
constexpr double kRaisedShare = 0.5;    // a cell above this share of the part's height there is raised
constexpr int kMaxDisagreeing = 4;      // an edge with more than 1/this of its cells disagreeing is not used

// For every low outline sample: walk across the outline, classify the cells as raised (above half the
// part's height there) or table, and put the edge where the fewest cells disagree. Adds the residual of the
// edge found (along the outward normal) to the (yaw, x, y) normal equations.
int add_outline_terms(const ScenePoints& c, const PartModel& m, const Iso3& P, const PlanarIcpSetting& s,
                      Mat3& A, Vec3& b) {
  if (m.outline.empty() || !c.low_sum) return 0;
  const Iso3 T = P.inverse();  // part -> table
  int used = 0;
  const int steps = s.outline_steps;
  std::vector<int> cls(static_cast<size_t>(steps));  // 1 raised, 0 table, -1 no data
  for (const PartModel::OutlineSample& o : m.outline) {
    if (o.top > c.outline_max_top) continue;
    int known = 0, raised = 0;
    for (int k = 0; k < steps; ++k) {
      const Eigen::Vector2d x = o.at + s.outline_step_m * (k - steps / 2) * o.out;
      const Vec3 q = T * Vec3(x.x(), x.y(), 0.0);
      const long i = c.low.index(q.x(), q.y());
      int& ck = cls[static_cast<size_t>(k)];
      ck = -1;
      if (i < 0 || c.low_count[static_cast<size_t>(i)] == 0) continue;
      ck = c.low_sum[static_cast<size_t>(i)] / c.low_count[static_cast<size_t>(i)] > kRaisedShare * o.top;
      ++known;
      raised += ck;
    }
    if (known < s.outline_min_known || raised == 0 || raised == known) continue;
    // Edge between step e-1 and e: disagreements = raised cells outside + table cells inside. Where cells
    // without returns leave a tie, they are the shadow the raised part casts on the table behind its edge:
    // the edge is at the raised end of the gap, the innermost of the tied positions.
    int best = 1 << 30, best_e = 0;
    for (int e = 0; e <= steps; ++e) {
      int cost = 0;
      for (int k = 0; k < steps; ++k) {
        const int ck = cls[static_cast<size_t>(k)];
        if (ck >= 0) cost += (k >= e) ? ck == 1 : ck == 0;
      }
      if (cost < best) best = cost, best_e = e;
    }
    const double t = s.outline_step_m * (best_e - 0.5 - steps / 2);  // edge offset along the outward normal
    if (std::abs(t) > s.outline_max_offset_m || best > known / kMaxDisagreeing) continue;
    const Eigen::Vector2d e2 = o.at + t * o.out;
    const Vec3 J(e2.x() * o.out.y() - e2.y() * o.out.x(), o.out.x(), o.out.y());
    A += J * J.transpose();
    b -= J * t;
    ++used;
  }
  return used;
}

}  // namespace

std::vector<ScanPoint> points_near_pose(const std::vector<ScanPoint>& from, PartModel& model, const Iso3& P,
                                        const PlanarIcpSetting& s) {
  std::vector<ScanPoint> near;
  const double m = s.box_margin_m;
  for (const ScanPoint& sp : from) {
    const Vec3& q = sp.raw;
    const Vec3 p = P * q;
    if (p.x() < model.lo.x() - m || p.y() < model.lo.y() - m || p.x() > model.hi.x() + m ||
        p.y() > model.hi.y() + m)
      continue;
    const int k = model.nearest(p);
    if (k >= 0 && std::abs(model.nrm[static_cast<size_t>(k)].z()) > s.level_normal_z &&
        (p - model.pts[static_cast<size_t>(k)]).norm() < s.level_depth_m)
      continue;
    near.push_back(sp);
  }
  return near;
}

IcpResult planar_icp(const std::vector<ScanPoint>& scan, const ScenePoints& c, PartModel& m, Iso3 P,
                     int iterations, bool fine, const PlanarIcpSetting& s) {
  IcpResult out;
  const NoiseLimits& lim = c.limits;
  // Far from the answer, a few closed-form point-to-point steps (each scan point moved onto its nearest
  // visible model sample) pull in faster and more steadily than linearized point-to-plane steps.
  for (int it = 0; !fine && it < s.point_to_point_iterations; ++it) {
    std::vector<Vec3> from, to;
    for (const ScanPoint& sp : scan) {
      const Vec3 p = P * sp.raw;
      const int k = m.nearest(p);
      if (k < 0 || !m.visible[static_cast<size_t>(k)] ||
          (p - m.pts[static_cast<size_t>(k)]).norm() > s.start_distance_m)
        continue;
      from.push_back(p);
      to.push_back(m.pts[static_cast<size_t>(k)]);
    }
    if (from.size() < kMinPointPairs) break;
    P = planar_rigid_fit(from, to) * P;
  }
  const bool cast = fine && !scan.empty() && scan.front().range > 0;
  const double in_plane2 = s.in_plane_spacings * s.in_plane_spacings * m.spacing_m * m.spacing_m;
  std::vector<int> face;
  const double edge_bias_m = s.rays.mixed_pixel_share * lim.trim_m / 2;
  const std::vector<uint8_t> near_edge = fine && cast && s.rays.mark_depth_edges
                                             ? rays_near_depth_edges(scan, m, P, s.rays)
                                             : std::vector<uint8_t>(scan.size(), 0);
  for (int it = 0; it < iterations; ++it) {
    const double f = iterations > 1 ? static_cast<double>(it) / (iterations - 1) : 1.0;
    const double max_d = std::max(lim.trim_m, s.start_distance_m + f * (lim.trim_m - s.start_distance_m));
    Mat3 A = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int used = 0;
    if (cast) {
      // Each ray is matched with the face it would meet were the pose right: the choice depends on where the
      // sensor looked, never on where the range noise threw the point, so no sign of the noise is dropped.
      match_rays(scan, m, P, lim.edge_margin_m, s.rays, face);
      for (size_t i = 0; i < scan.size(); ++i) {
        if (face[i] < 0) continue;
        const size_t kk = static_cast<size_t>(face[i]);
        const Vec3& n = m.nrm[kk];
        const Vec3 p = P * scan[i].raw;
        const double r = (p - m.pts[kk]).dot(n);
        const Vec3 J(p.x() * n.y() - p.y() * n.x(), n.x(), n.y());
        if (std::abs(r) > max_d) {
          if (fine && it == iterations - 1)
            out.beyond_trim.push_back({J, std::copysign(max_d, r), 1.0, m.pts[kk]});
          continue;
        }
        A += J * J.transpose();
        b -= J * r;
        ++used;
        if (fine && it == iterations - 1)
          out.terms.push_back({J, r, 1.0, m.pts[kk], near_edge[i] ? edge_bias_m : 0.0});
      }
    }
    for (const ScanPoint& sp : scan) {
      if (cast) break;  // the rays have been matched above
      const Vec3 p = P * sp.raw;
      const int k = m.nearest(P * sp.smooth);
      if (k < 0) continue;
      const size_t kk = static_cast<size_t>(k);
      if (m.edge_distance[kk] < lim.edge_margin_m) continue;
      const Vec3& n = m.nrm[kk];
      const Vec3 d = p - m.pts[kk];
      const double r = d.dot(n);
      if ((d - r * n).squaredNorm() > in_plane2) continue;
      const Vec3 J(p.x() * n.y() - p.y() * n.x(), n.x(), n.y());
      const double h = m.half_thickness[kk];
      double limit = max_d;
      if (fine && h < lim.trim_m) {
        // A thin wall, seen on both sides: noise this wide carries points across its middle, so a point
        // taken for the side seen less (an inner wall seen only steeply) may well belong to the other side.
        // Only the better-seen side is used, trimmed at the middle so its own noise stays symmetric.
        const int kb = m.nearest(m.pts[kk] - 2 * h * n);
        if (kb >= 0 && m.nrm[static_cast<size_t>(kb)].dot(n) < kOppositeFace &&
            m.view_score[static_cast<size_t>(kb)] > m.view_score[kk])
          continue;
        limit = std::min(max_d, h);
      }
      if (!m.visible[kk] || std::abs(r) > limit) continue;
      A += J * J.transpose();
      b -= J * r;
      ++used;
      if (fine && it == iterations - 1) out.terms.push_back({J, r, 1.0, m.pts[kk]});
    }
    // Without rays, the outline of a part too low to be told from the table is read from the height step;
    // with them, the plate's own walls take part (the rays tell them from the table).
    if (!cast) used += add_outline_terms(c, m, P, s, A, b);
    out.iterations = it + 1;
    if (used < s.min_correspondences) break;
    A += kDamping * Mat3::Identity();
    const Vec3 xi = A.ldlt().solve(b);
    P = planar_pose(xi.y(), xi.z(), 0.0, xi.x()) * P;
    if (f >= 1.0) out.converged = std::abs(xi.x()) * s.yaw_lever_m + xi.tail<2>().norm() < s.converged_step_m;
  }
  out.P = orthonormalized(P);
  return out;
}

}  // namespace weldtwin
