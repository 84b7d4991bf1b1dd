#include "planning/torch_frame.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {
namespace {

Vec3 orthogonal_to(const Vec3& v, const Vec3& d) {
  return (v - v.dot(d) * d).normalized();
}

}  // namespace

TorchAxes torch_axes(const Vec3& d_in, const Vec3& n_in, const Vec3& m_in, double work, double travel) {
  const Vec3 d = d_in.normalized();
  const Vec3 n = orthogonal_to(n_in, d), m = orthogonal_to(m_in, d);
  const Vec3 a0 = -(std::cos(work) * n + std::sin(work) * m).normalized();
  TorchAxes axes;
  axes.a = (std::cos(travel) * a0 + std::sin(travel) * d).normalized();
  axes.x0 = orthogonal_to(d, axes.a);
  return axes;
}

Mat3 torch_orientation(const TorchAxes& axes, double roll) {
  Mat3 R;
  R.col(2) = axes.a;
  R.col(0) = Eigen::AngleAxisd(roll, axes.a) * axes.x0;
  R.col(1) = axes.a.cross(R.col(0));
  return R;
}

Mat3 torch_orientation(const Vec3& d, const Vec3& n, const Vec3& m, double work, double travel, double roll) {
  return torch_orientation(torch_axes(d, n, m, work, travel), roll);
}

void torch_angles(const Mat3& R_base_tcp, const Vec3& d_in, const Vec3& n_in, const Vec3& m_in, double& work,
                  double& travel) {
  const Vec3 d = d_in.normalized();
  const Vec3 n = orthogonal_to(n_in, d), m = orthogonal_to(m_in, d);
  const Vec3 a = R_base_tcp.col(2);
  // a = cos(tau) a0 + sin(tau) d with a0 normal to d: the travel angle is the axis' component along d.
  travel = std::asin(std::clamp(a.dot(d), -1.0, 1.0));
  const Vec3 a0 = (a - a.dot(d) * d).normalized();
  // -a0 = cos w n + sin w m: solve in the (n, m) basis (not orthonormal in general).
  const Vec3 b = -a0;
  const double nn = n.dot(n), nm = n.dot(m), mm = m.dot(m), bn = b.dot(n), bm = b.dot(m);
  const double det = nn * mm - nm * nm;
  const double c = (bn * mm - bm * nm) / det, s = (bm * nn - bn * nm) / det;
  work = std::atan2(s, c);
}

}  // namespace weldtwin
