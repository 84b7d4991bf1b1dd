// The pose's uncertainty where a direction rests on a few cells of the scan: how many cells inform a motion,
// the widening of the bound's quantile as they become few, and the bound's cover over seeded draws in which
// each cell of a wall carries its own error (a stretch of wall warped, blended with its edge) besides the
// noise, as the ends of a tube seen across carry the tube's place along its length.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>

#include "perception/localize/pose_uncertainty.hpp"

namespace weldtwin {
namespace {

constexpr double kCell = 0.01;  // the setting's default cell [m]

// A planar fit's residuals: y and the turn held by `wide` terms spread along two long walls facing +-y
// (one cell each), x by `per_end` terms in each of `ends` cells on walls facing +x (placed about y = 0, so
// that they say nothing of the turn). Each x cell's terms
// share one error N(0, cell_sigma) besides their own N(0, sigma); the fit is solved (least squares, all
// weights 1) and the residuals are those it leaves. Returns the terms and, in `error`, the fit's (x, y)
// error at the origin.
std::vector<ResidualTerm> fitted_terms(int ends, int per_end, int wide, double cell_sigma, double sigma,
                                       std::mt19937_64& rng, Eigen::Vector2d& error) {
  std::normal_distribution<double> noise(0.0, sigma), shared(0.0, cell_sigma);
  std::vector<ResidualTerm> terms;
  std::vector<double> r0;
  for (int c = 0; c < ends; ++c) {
    const double e = shared(rng);
    const Vec3 at(0.2, 1.5 * kCell * (c - 0.5 * (ends - 1)), 0.03);  // one cell each, about y = 0
    for (int i = 0; i < per_end; ++i) {
      terms.push_back({Vec3(-at.y(), 1.0, 0.0), 0.0, 1.0, at});
      r0.push_back(e + noise(rng));
    }
  }
  for (int i = 0; i < wide; ++i) {
    const double x = -0.2 + 0.4 * (i + 0.5) / wide;
    for (double side : {-1.0, 1.0}) {
      const Vec3 at(x, 0.05 * side, 0.03);
      terms.push_back({Vec3(x * side, 0.0, side), 0.0, 1.0, at});
      r0.push_back(noise(rng));
    }
  }
  Mat3 H = Mat3::Zero();
  Vec3 b = Vec3::Zero();
  for (size_t i = 0; i < terms.size(); ++i) {
    H += terms[i].J * terms[i].J.transpose();
    b += terms[i].J * r0[i];
  }
  const Vec3 xi = H.ldlt().solve(b);  // the fit's error in (yaw, x, y)
  for (size_t i = 0; i < terms.size(); ++i) terms[i].r = r0[i] - terms[i].J.dot(xi);
  error = xi.tail<2>();
  return terms;
}

double largest_eigenvalue(const Eigen::Matrix2d& C) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C).eigenvalues()(1);
}

TEST(PoseUncertainty, ADirectionHeldByAFewCellsCountsThoseCellsNotTheFits) {
  std::mt19937_64 rng(5);
  Eigen::Vector2d error;
  const PoseUncertainty u = pose_uncertainty(fitted_terms(5, 40, 300, 0.0, 0.001, rng, error));
  ASSERT_TRUE(u.ok);
  EXPECT_GT(u.clusters, 60);
  EXPECT_NEAR(effective_cells(u, Vec3::UnitY()), 5.0, 0.01);  // x: the five end cells, equally
  EXPECT_GT(effective_cells(u, Vec3::UnitZ()), 40.0);         // y: the long walls' cells
}

TEST(PoseUncertainty, TheQuantileWidensAsTheCellsBecomeFew) {
  const double many = confidence_scale2(std::numeric_limits<double>::infinity());
  EXPECT_NEAR(many, 7.815, 0.001);  // chi-square, 3 degrees of freedom, 95 %
  EXPECT_NEAR(std::sqrt(confidence_scale2(5.0)), 2.796 * 2.776 / 1.960, 0.005);  // t with 4 dof
  EXPECT_NEAR(confidence_scale2(1000.0), many, 0.02);
  EXPECT_GT(confidence_scale2(5.0), confidence_scale2(10.0));
  EXPECT_TRUE(std::isinf(confidence_scale2(2.0)));
}

TEST(PoseUncertainty, ABoundOnAFewCellsCoversItsStatedFractionWhereTheLargeSampleOneDoesNot) {
  // Five end cells, each off by its own 1 mm: the fit's x is their mean, and the spread of five cell sums
  // is all the sandwich has to judge it by. Over 4,000 draws the bound must hold in at least 95 % of them;
  // the same covariance with the large-sample quantile (2.8 sd) holds in about 93 %.
  std::mt19937_64 rng(11);
  const int draws = 4000;
  int covered = 0, covered_large = 0;
  const std::vector<Vec3> origin{Vec3::Zero()};
  const double large = confidence_scale2(std::numeric_limits<double>::infinity());
  for (int k = 0; k < draws; ++k) {
    Eigen::Vector2d error;
    const PoseUncertainty u = pose_uncertainty(fitted_terms(5, 40, 300, 0.001, 0.0003, rng, error));
    ASSERT_TRUE(u.ok);
    const SeamBound b = seam_error_bound(u, origin);
    covered += error.norm() <= b.bound_m;
    const Eigen::Matrix2d C = u.covariance.bottomRightCorner<2, 2>();
    covered_large += error.norm() <= std::sqrt(large * largest_eigenvalue(C));
    if (k == 0) {
      EXPECT_NEAR(b.cells, 5.0, 0.01);
      EXPECT_GT(std::abs(b.direction.x()), 0.99);  // the bound's direction: along x
    }
  }
  EXPECT_GE(covered, static_cast<int>(0.95 * draws)) << covered << " of " << draws;
  EXPECT_LT(covered_large, static_cast<int>(0.95 * draws)) << covered_large << " of " << draws;
  std::printf("five cells: the bound held in %d of %d draws, the large-sample one in %d\n", covered, draws,
              covered_large);
}

TEST(PoseUncertainty, ManyCellsLeaveTheBoundAsTheLargeSampleOne) {
  // Held everywhere by hundreds of cells, the bound is the 3-dof region's within 2 %.
  std::mt19937_64 rng(2);
  Eigen::Vector2d error;
  const PoseUncertainty u = pose_uncertainty(fitted_terms(300, 2, 300, 0.0, 0.001, rng, error));
  ASSERT_TRUE(u.ok);
  const std::vector<Vec3> seam{Vec3(0.1, 0.0, 0.05)};
  const Eigen::Matrix<double, 2, 3> J = planar_move_jacobian(seam[0]);
  const double large = std::sqrt(confidence_scale2(std::numeric_limits<double>::infinity()) *
                                 largest_eigenvalue(J * u.covariance * J.transpose()));
  EXPECT_NEAR(seam_error_bound_m(u, seam) / large, 1.0, 0.02);
}

}  // namespace
}  // namespace weldtwin
