#include "perception/localize/pose_uncertainty.hpp"

#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include <Eigen/Eigenvalues>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>

namespace weldtwin {
namespace {

constexpr int kMinClusters = 6;  // fewer cells: the spread of their sums says too little

long long cell_key(const Vec3& p, double cell) {
  const long long ix = static_cast<long long>(std::floor(p.x() / cell)),
                  iy = static_cast<long long>(std::floor(p.y() / cell)),
                  iz = static_cast<long long>(std::floor(p.z() / cell));
  return (ix * 1000003LL + iy) * 1000003LL + iz;
}

}  // namespace

PoseUncertainty pose_uncertainty(const std::vector<ResidualTerm>& terms, const PoseUncertaintySetting& s) {
  PoseUncertainty out;
  Mat3 H = Mat3::Zero();
  std::unordered_map<long long, Vec3> g, unseen;
  std::unordered_map<long long, Eigen::Matrix<double, 6, 1>> info;  // each cell's H_g as h_g
  double wr2 = 0.0, wsum = 0.0;
  for (const ResidualTerm& t : terms) {
    if (t.w <= 0.0) continue;
    H += t.w * t.J * t.J.transpose();
    wr2 += t.w * t.r * t.r;
    wsum += t.w;
    auto it = g.try_emplace(cell_key(t.at, s.cluster_cell_m), Vec3::Zero()).first;
    it->second += t.w * t.r * t.J;
    Eigen::Matrix<double, 6, 1> h;
    h << t.J.x() * t.J.x(), t.J.y() * t.J.y(), t.J.z() * t.J.z(), t.J.x() * t.J.y(), t.J.x() * t.J.z(),
        t.J.y() * t.J.z();
    info.try_emplace(it->first, Eigen::Matrix<double, 6, 1>::Zero()).first->second += t.w * h;
    if (t.unseen_sigma_m > 0.0)
      unseen.try_emplace(it->first, Vec3::Zero()).first->second += t.w * t.unseen_sigma_m * t.J;
  }
  out.clusters = static_cast<int>(g.size());
  if (out.clusters < kMinClusters) return out;
  Mat3 B = Mat3::Zero();
  for (const auto& [key, gc] : g) B += gc * gc.transpose();
  // Small-sample correction of the cluster sums: G / (G - k) with k = 3 parameters.
  B *= static_cast<double>(out.clusters) / static_cast<double>(out.clusters - 3);
  for (const auto& [key, gu] : unseen) B += gu * gu.transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(H);
  if (eig.eigenvalues().minCoeff() <= 1e-12 * std::max(1.0, eig.eigenvalues().maxCoeff())) return out;
  const Mat3 Hi =
      eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  out.covariance = Hi * B * Hi;
  out.information_inverse = Hi;
  for (const auto& [key, h] : info) out.cell_information_moments += h * h.transpose();
  out.residual_sigma_m = std::sqrt(wr2 / wsum);
  // Design effect: the generalized eigenvalues of the sandwich against sigma^2 H^-1, i.e. of B against
  // sigma^2 H (B v = lambda sigma^2 H v), the largest.
  {
    const Eigen::GeneralizedSelfAdjointEigenSolver<Mat3> ge(B, wr2 / wsum * H);
    out.design_effect = std::max(1.0, ge.eigenvalues().maxCoeff());
  }
  out.ok = out.covariance.allFinite();
  return out;
}

double effective_cells(const PoseUncertainty& u, const Vec3& c) {
  if (!u.ok) return 0.0;
  const Vec3 a = u.information_inverse * c;
  const double total = c.dot(a);  // sum_g a^T H_g a
  if (!(total > 0.0)) return 0.0;
  // a^T H_g a = w . h_g, so sum_g (a^T H_g a)^2 = w^T (sum_g h_g h_g^T) w.
  Eigen::Matrix<double, 6, 1> w;
  w << a.x() * a.x(), a.y() * a.y(), a.z() * a.z(), 2 * a.x() * a.y(), 2 * a.x() * a.z(), 2 * a.y() * a.z();
  const double sum2 = w.dot(u.cell_information_moments * w);
  return sum2 > 0.0 ? total * total / sum2 : 0.0;
}

double confidence_scale2(double cells, const PoseUncertaintySetting& s) {
  namespace bm = boost::math;
  constexpr double k = 3.0;  // (yaw, x, y)
  const double region = bm::quantile(bm::chi_squared(k), s.confidence);
  if (std::isinf(cells)) return region;
  if (!(cells > 2.0)) return std::numeric_limits<double>::infinity();
  // A two-sided interval on one direction: Student's t with G - 1 degrees of freedom against the normal's.
  const double tail = 0.5 * (1.0 + s.confidence);
  const double t = bm::quantile(bm::students_t(cells - 1.0), tail), z = bm::quantile(bm::normal(), tail);
  return region * (t * t) / (z * z);
}

Eigen::Matrix<double, 2, 3> planar_move_jacobian(const Vec3& p) {
  Eigen::Matrix<double, 2, 3> J;
  J << -p.y(), 1.0, 0.0, p.x(), 0.0, 1.0;
  return J;
}

SeamBound seam_error_bound(const PoseUncertainty& u, const std::vector<Vec3>& points,
                           const PoseUncertaintySetting& s) {
  SeamBound out;
  if (!u.ok) return out;
  // A point p moves by (-theta p_y + x, theta p_x + y) under the perturbation (theta, x, y); over the
  // confidence ellipsoid xi^T Cov^-1 xi <= q its largest move along a unit v is sqrt(q v^T J Cov J^T v),
  // largest along the principal directions of J Cov J^T, with q from the cells that inform that move.
  // The quantile for the whole count of cells below (fewer: wider, so never narrower than the exact one),
  // each count's computed once.
  constexpr int kCountedCells = 1000;  // more count as this many (the quantile within 0.1 % of many's)
  std::vector<double> scale2(kCountedCells + 1, -1.0);
  auto scale2_for = [&](double cells) {
    const int n = static_cast<int>(std::floor(std::min<double>(cells + 1e-9, kCountedCells)));
    double& q = scale2[static_cast<size_t>(n)];
    if (q < 0.0) q = confidence_scale2(n, s);
    return q;
  };
  double worst = 0.0;
  for (const Vec3& p : points) {
    const Eigen::Matrix<double, 2, 3> J = planar_move_jacobian(p);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(J * u.covariance * J.transpose());
    for (int axis = 0; axis < 2; ++axis) {
      const Eigen::Vector2d v = eig.eigenvectors().col(axis);
      const double cells = effective_cells(u, J.transpose() * v);
      const double reach2 = scale2_for(cells) * eig.eigenvalues()(axis);
      if (reach2 > worst) {
        worst = reach2;
        out.direction = v;
        out.cells = cells;
      }
    }
  }
  out.bound_m = points.empty() ? 0.0 : std::sqrt(worst);
  return out;
}

double seam_error_bound_m(const PoseUncertainty& u, const std::vector<Vec3>& points,
                          const PoseUncertaintySetting& s) {
  return seam_error_bound(u, points, s).bound_m;
}

double yaw_bound_rad(const PoseUncertainty& u, const PoseUncertaintySetting& s) {
  if (!u.ok) return std::numeric_limits<double>::infinity();
  return std::sqrt(confidence_scale2(effective_cells(u, Vec3::UnitX()), s) * u.covariance(0, 0));
}

double wall_side_bias_m(double t, double sigma) {
  if (t <= 0.0 || sigma <= 0.0) return 0.0;
  const double q = 0.5 * std::erfc(t / (2.0 * sigma) / std::sqrt(2.0));  // Phi(-t / 2 sigma)
  return 2.0 * q * t;
}

}  // namespace weldtwin
