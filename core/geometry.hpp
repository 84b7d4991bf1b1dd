// Small geometry helpers shared by every layer: transforms from URDF-style xyz/rpy, angle conversions and
// transform (re)orthonormalisation. Frames follow REP-103: T_a_b maps b coordinates into a.
#pragma once

#include <Eigen/Geometry>
#include <cmath>

namespace weldtwin {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Iso3 = Eigen::Isometry3d;
using Quat = Eigen::Quaterniond;

constexpr double kPi = 3.14159265358979323846;
inline constexpr double deg2rad(double deg) {
  return deg * kPi / 180.0;
}
inline constexpr double rad2deg(double rad) {
  return rad * 180.0 / kPi;
}

/// URDF rotation convention: R = Rz(yaw) * Ry(pitch) * Rx(roll), fixed axes.
inline Mat3 rpy_to_matrix(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll, Vec3::UnitX()))
      .toRotationMatrix();
}

inline Iso3 make_transform(const Vec3& xyz, const Mat3& R) {
  Iso3 T = Iso3::Identity();
  T.linear() = R;
  T.translation() = xyz;
  return T;
}

/// A pose on the table: translation (x, y, z) and a rotation about +z.
inline Iso3 planar_pose(double x, double y, double z, double yaw) {
  return make_transform(Vec3(x, y, z), Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix());
}

/// Rotation about the z axis by `angle` [rad].
inline Mat3 rot_z(double angle) {
  return Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
}

/// Projects the rotation part back onto SO(3) (polar decomposition through the SVD).
inline Iso3 orthonormalized(const Iso3& T) {
  Eigen::JacobiSVD<Mat3> svd(T.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Mat3 U = svd.matrixU();
    U.col(2) *= -1.0;
    R = U * svd.matrixV().transpose();
  }
  return make_transform(T.translation(), R);
}

/// (1 - u) A + u B entry by entry: for poses a few milliseconds of motion apart, where it is the motion to
/// far under a micrometre (the rotation is off SO(3) by the square of the angle between them).
inline Iso3 lerp_pose(const Iso3& A, const Iso3& B, double u) {
  Iso3 T = A;
  T.translation() = (1.0 - u) * A.translation() + u * B.translation();
  T.linear() = (1.0 - u) * A.linear() + u * B.linear();
  return T;
}

}  // namespace weldtwin
