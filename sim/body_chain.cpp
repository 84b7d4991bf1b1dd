#include "sim/body_chain.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace weldtwin {

BodyChain::BodyChain(const mjModel* m, int body, const std::vector<int>& qpos_adr) {
  for (int b = body; b > 0; b = m->body_parentid[b]) {
    Link link;
    const mjtNum* q = m->body_quat + 4 * b;
    link.T_parent_body =
        make_transform(Vec3(m->body_pos[3 * b], m->body_pos[3 * b + 1], m->body_pos[3 * b + 2]),
                       Quat(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix());
    if (m->body_jntnum[b] > 1) throw std::invalid_argument("BodyChain: a body with several joints");
    if (m->body_jntnum[b] == 1) {
      const int j = m->body_jntadr[b];
      if (m->jnt_type[j] != mjJNT_HINGE) throw std::invalid_argument("BodyChain: only hinge joints");
      const mjtNum* p = m->jnt_pos + 3 * j;
      if (p[0] != 0.0 || p[1] != 0.0 || p[2] != 0.0)
        throw std::invalid_argument("BodyChain: hinge off the origin");
      const auto it = std::find(qpos_adr.begin(), qpos_adr.end(), m->jnt_qposadr[j]);
      if (it == qpos_adr.end()) throw std::invalid_argument("BodyChain: a joint that is not the arm's");
      link.q_index = static_cast<int>(it - qpos_adr.begin());
      link.axis = Vec3(m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]).normalized();
      link.axis_is_z = link.axis == Vec3::UnitZ();
    }
    links_.push_back(link);
  }
  std::reverse(links_.begin(), links_.end());
}

void BodyChain::turn(const Link& l, const JointVector& q, Mat3& R) {
  // R * Rot(axis, q): about z (every joint of our arm) on two columns only.
  if (l.q_index < 0) return;
  const double c = std::cos(q[l.q_index]), s = std::sin(q[l.q_index]);
  if (l.axis_is_z) {
    const Vec3 x = R.col(0), y = R.col(1);
    R.col(0) = c * x + s * y;
    R.col(1) = c * y - s * x;
  } else {
    R = R * Eigen::AngleAxisd(q[l.q_index], l.axis).toRotationMatrix();
  }
}

Iso3 BodyChain::pose(const JointVector& q) const {
  // Runs once per LiDAR sample: plain 3x3 algebra, and a rotation about z done on two columns.
  Mat3 R = Mat3::Identity();
  Vec3 p = Vec3::Zero();
  for (const Link& l : links_) {
    p += R * l.T_parent_body.translation();
    R = R * l.T_parent_body.linear();
    turn(l, q, R);
  }
  return make_transform(p, R);
}

}  // namespace weldtwin

namespace weldtwin {

Iso3 BodyChain::pose(const JointVector& q, Cache& cache) const {
  const size_t n = links_.size();
  const bool fresh = cache.R.size() != n + 1;
  if (fresh) {
    cache.R.assign(n + 1, Mat3::Identity());
    cache.p.assign(n + 1, Vec3::Zero());
  }
  // The last link whose joint changed bounds what must be recomputed; a fresh cache recomputes everything.
  size_t dirty = n - 1;
  bool any = fresh;
  if (!fresh) {
    dirty = 0;
    for (size_t k = 0; k < n; ++k) {
      const int j = links_[k].q_index;
      if (j >= 0 && q[j] != cache.q[j]) {
        dirty = k;
        any = true;
      }
    }
  }
  if (!any) return make_transform(cache.p[0], cache.R[0]);
  for (size_t k = dirty + 1; k-- > 0;) {
    // S_k = A_k Rot_k(q) S_{k+1}
    const Link& l = links_[k];
    Mat3 R = l.T_parent_body.linear();
    turn(l, q, R);
    cache.p[k] = l.T_parent_body.translation() + R * cache.p[k + 1];
    cache.R[k] = R * cache.R[k + 1];
  }
  cache.q = q;
  return make_transform(cache.p[0], cache.R[0]);
}

}  // namespace weldtwin
