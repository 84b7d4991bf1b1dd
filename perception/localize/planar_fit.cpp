#include "perception/localize/planar_fit.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace weldtwin {

Iso3 planar_rigid_fit(const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
  const size_t n = std::min(from.size(), to.size());
  if (n == 0) return Iso3::Identity();
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < n; ++i) ca += from[i].head<2>(), cb += to[i].head<2>();
  ca /= static_cast<double>(n);
  cb /= static_cast<double>(n);
  // Cross-covariance H = sum (a - ca)(b - cb)^T; R = V U^T (Umeyama 1991, eq. 39, in 2D).
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < n; ++i) H += (from[i].head<2>() - ca) * (to[i].head<2>() - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix2d R = svd.matrixV() * svd.matrixU().transpose();
  if (R.determinant() < 0) {  // a reflection is no motion: flip the weaker axis
    Eigen::Matrix2d V = svd.matrixV();
    V.col(1) *= -1;
    R = V * svd.matrixU().transpose();
  }
  const Eigen::Vector2d t = cb - R * ca;
  return planar_pose(t.x(), t.y(), 0.0, std::atan2(R(1, 0), R(0, 0)));
}

}  // namespace weldtwin
