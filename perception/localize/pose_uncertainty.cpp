#include "perception/localize/pose_uncertainty.hpp"

#include <cmath>
#include <limits>
#include <unordered_map>

#include <Eigen/Eigenvalues>

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
  double wr2 = 0.0, wsum = 0.0;
  for (const ResidualTerm& t : terms) {
    if (t.w <= 0.0) continue;
    H += t.w * t.J * t.J.transpose();
    wr2 += t.w * t.r * t.r;
    wsum += t.w;
    auto it = g.try_emplace(cell_key(t.at, s.cluster_cell_m), Vec3::Zero()).first;
    it->second += t.w * t.r * t.J;
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

Eigen::Matrix<double, 2, 3> planar_move_jacobian(const Vec3& p) {
  Eigen::Matrix<double, 2, 3> J;
  J << -p.y(), 1.0, 0.0, p.x(), 0.0, 1.0;
  return J;
}

double seam_error_bound_m(const PoseUncertainty& u, const std::vector<Vec3>& points,
                          const PoseUncertaintySetting& s) {
  if (!u.ok) return std::numeric_limits<double>::infinity();
  // A point p moves by (-theta p_y + x, theta p_x + y) under the perturbation (theta, x, y); over the
  // confidence ellipsoid xi^T Cov^-1 xi <= chi2 its largest move is sqrt(chi2 lambda_max(J Cov J^T)).
  double worst = 0.0;
  for (const Vec3& p : points) {
    const Eigen::Matrix<double, 2, 3> J = planar_move_jacobian(p);
    const Eigen::Matrix2d C = J * u.covariance * J.transpose();
    const double lmax = 0.5 * (C.trace() + std::sqrt(std::pow(C(0, 0) - C(1, 1), 2) + 4 * C(0, 1) * C(0, 1)));
    worst = std::max(worst, lmax);
  }
  return std::sqrt(s.chi2_3dof * worst);
}

double yaw_bound_rad(const PoseUncertainty& u, const PoseUncertaintySetting& s) {
  if (!u.ok) return std::numeric_limits<double>::infinity();
  return std::sqrt(s.chi2_3dof * u.covariance(0, 0));
}

double wall_side_bias_m(double t, double sigma) {
  if (t <= 0.0 || sigma <= 0.0) return 0.0;
  const double q = 0.5 * std::erfc(t / (2.0 * sigma) / std::sqrt(2.0));  // Phi(-t / 2 sigma)
  return 2.0 * q * t;
}

}  // namespace weldtwin
