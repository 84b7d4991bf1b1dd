// The torch orientation of docs/design.md, from a seam's travel direction d, its normals n and m, and the
// work, travel and roll angles:
//   a0 = -(cos w n + sin w m)   (n, m made orthogonal to d; w = 45 deg bisects a fillet)
//   a  = cos(tau) a0 + sin(tau) d   (travel angle tau, push positive)
//   z_tcp = a; x_tcp = d made orthogonal to a, turned by the roll about a; y = z x x.
#pragma once

#include "core/geometry.hpp"

namespace weldtwin {

/// The torch's axis `a` (z_tcp) and its direction at roll 0 (`x0`) for the given seam directions (base
/// frame) and work and travel angles [rad]: what a pose's roll turns about.
struct TorchAxes {
  Vec3 a = Vec3::UnitZ(), x0 = Vec3::UnitX();
};
TorchAxes torch_axes(const Vec3& d, const Vec3& n, const Vec3& m, double work, double travel);

/// R_base_tcp: the axes turned by the roll [rad] about `a`.
Mat3 torch_orientation(const TorchAxes& axes, double roll);

/// R_base_tcp for the given seam directions (base frame) and angles [rad].
Mat3 torch_orientation(const Vec3& d, const Vec3& n, const Vec3& m, double work, double travel, double roll);

/// The work and travel angles of a torch orientation with respect to a seam: the inverse of the above.
void torch_angles(const Mat3& R_base_tcp, const Vec3& d, const Vec3& n, const Vec3& m, double& work,
                  double& travel);

}  // namespace weldtwin
