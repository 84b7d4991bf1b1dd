#include "sim/contact_screen.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "sim/contact_prefilter.hpp"

namespace weldtwin {
namespace {

bool collidable(const mjModel* m, int g) {
  return m->geom_contype[g] != 0 || m->geom_conaffinity[g] != 0;
}

bool compatible(const mjModel* m, int g1, int g2) {
  return (m->geom_contype[g1] & m->geom_conaffinity[g2]) != 0 ||
         (m->geom_contype[g2] & m->geom_conaffinity[g1]) != 0;
}

// MuJoCo's filters on a pair of bodies: the same weld body (both static, or welded together), a weld body and
// its weld parent (unless the parent filter is disabled; never with the world), an <exclude>.
bool filtered(const mjModel* m, int b1, int b2) {
  const int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
  if (w1 == w2) return true;
  if (!(m->opt.disableflags & mjDSBL_FILTERPARENT) && w1 != 0 && w2 != 0) {
    const int p1 = m->body_weldid[m->body_parentid[w1]], p2 = m->body_weldid[m->body_parentid[w2]];
    if (w1 == p2 || w2 == p1) return true;
  }
  const int lo = std::min(b1, b2), hi = std::max(b1, b2);
  for (int e = 0; e < m->nexclude; ++e) {
    const int s = m->exclude_signature[e];
    if (s == (lo << 16) + hi || s == (hi << 16) + lo) return true;
  }
  return false;
}

double distance(const double* a, const double* b) {
  const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return std::sqrt(x * x + y * y + z * z);
}

// A lower bound of the distance from a sphere (centre `c`, radius `r`, world) to the static geom `h`,
// negative when they may overlap: exact for a box, a cylinder and a plane's half-space (a plane's contacts
// lie on or below it), the geom's bounding sphere for any other shape.
double sphere_gap(const mjModel* m, const mjData* d, int h, const double* c, double r) {
  const mjtNum* x = d->geom_xpos + 3 * h;
  const mjtNum* R = d->geom_xmat + 9 * h;  // row-major: column k is the geom's axis k
  const double v[3] = {c[0] - x[0], c[1] - x[1], c[2] - x[2]};
  double p[3];  // the centre in the geom's frame
  for (int k = 0; k < 3; ++k) p[k] = v[0] * R[k] + v[1] * R[3 + k] + v[2] * R[6 + k];
  const mjtNum* size = m->geom_size + 3 * h;
  switch (m->geom_type[h]) {
    case mjGEOM_PLANE:
      return p[2] - r;
    case mjGEOM_BOX: {
      double out = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double e = std::max(std::abs(p[k]) - size[k], 0.0);
        out += e * e;
      }
      return std::sqrt(out) - r;
    }
    case mjGEOM_CYLINDER: {
      const double radial = std::max(std::sqrt(p[0] * p[0] + p[1] * p[1]) - size[0], 0.0);
      const double axial = std::max(std::abs(p[2]) - size[1], 0.0);
      return std::sqrt(radial * radial + axial * axial) - r;
    }
    default:
      return m->geom_rbound[h] > 0
                 ? std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - m->geom_rbound[h] - r
                 : -std::numeric_limits<double>::infinity();
  }
}

// Whether a sphere is farther than `margin` from the static geom `h`: by the geom's bounding sphere first (no
// square root, no turn into its frame), by its shape where that does not settle it.
bool sphere_clear(const mjModel* m, const mjData* d, int h, const double* c, double r, double margin) {
  const double rb = m->geom_rbound[h];
  if (rb > 0) {
    const mjtNum* x = d->geom_xpos + 3 * h;
    const double v[3] = {c[0] - x[0], c[1] - x[1], c[2] - x[2]}, reach = rb + r + margin;
    if (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > reach * reach) return true;
  }
  return sphere_gap(m, d, h, c, r) > margin;
}

double pair_margin(const mjModel* m, int g1, int g2) {
  return std::max(m->geom_margin[g1], m->geom_margin[g2]);
}

}  // namespace

ArmContactScreen::ArmContactScreen(const mjModel* m, const std::vector<Label>& labels)
    : body_sphere_(static_cast<size_t>(m->nbody)) {
  // Explicit <pair>s (MuJoCo collides them whatever their contact types, with margins of their own) and
  // overridden margins are not what the screen mirrors: then it answers nothing on its own.
  if (m->npair > 0 || (m->opt.enableflags & mjENBL_OVERRIDE)) {
    screens_ = false;
    return;
  }
  const auto arm = [&](int g) { return labels[static_cast<size_t>(g)] == Label::kRobot; };
  std::vector<std::vector<int>> geoms_of(static_cast<size_t>(m->nbody));
  for (int g = 0; g < m->ngeom; ++g)
    if (collidable(m, g)) geoms_of[static_cast<size_t>(m->geom_bodyid[g])].push_back(g);
  const auto moving = [&](int b) { return m->body_weldid[b] != 0; };

  // The pairs of body b's geoms with `others`, a row of them per geom of b.
  const auto pairs_between = [&](int b, const std::vector<int>& others, BodyPair& bp) {
    std::vector<GeomPair>& pairs = bp.pairs;
    for (int g : geoms_of[static_cast<size_t>(b)]) {
      const size_t first = pairs.size();
      for (int h : others) {
        if (!(arm(g) || arm(h)) || !compatible(m, g, h) || filtered(m, b, m->geom_bodyid[h])) continue;
        GeomPair p;
        p.g1 = m->geom_type[g] <= m->geom_type[h] ? g : h;
        p.g2 = p.g1 == g ? h : g;
        p.both_arm = arm(g) && arm(h);
        p.g1_arm = arm(p.g1);
        p.collide = prefiltered_collision_function(m->geom_type[p.g1], m->geom_type[p.g2]);
        if (p.collide) pairs.push_back(p);  // a pair of types MuJoCo has no function for never touches
      }
      if (pairs.size() > first) bp.rows.push_back({g, first, pairs.size()});
    }
  };
  for (int b = 1; b < m->nbody; ++b) {
    if (!moving(b) || geoms_of[static_cast<size_t>(b)].empty()) continue;
    for (int other = 0; other < m->nbody; ++other) {
      const std::vector<int>& others = geoms_of[static_cast<size_t>(other)];
      if (other == b || others.empty()) continue;
      if (moving(other)) {
        if (other < b) continue;  // that pair belongs to the other body
        BodyPair bp;
        bp.body = b, bp.other_body = other;
        pairs_between(b, others, bp);
        if (!bp.pairs.empty()) body_pairs_.push_back(std::move(bp));
      } else {
        for (int h : others) {
          BodyPair bp;
          bp.body = b, bp.other_body = other, bp.other_geom = h;
          pairs_between(b, {h}, bp);
          if (!bp.pairs.empty()) body_pairs_.push_back(std::move(bp));
        }
      }
    }
  }
  // Every moving body that appears in a pair (on either side) gets its sphere: round its collidable geoms'
  // bounding spheres, about their mean position in the body frame.
  std::vector<char> needed(static_cast<size_t>(m->nbody), 0);
  for (const BodyPair& bp : body_pairs_) {
    needed[static_cast<size_t>(bp.body)] = 1;
    if (bp.other_geom < 0) needed[static_cast<size_t>(bp.other_body)] = 1;
    pair_count_ += bp.pairs.size();
    for (const GeomPair& p : bp.pairs) margin_ = std::max(margin_, pair_margin(m, p.g1, p.g2));
  }
  for (int b = 0; b < m->nbody; ++b) {
    if (!needed[static_cast<size_t>(b)]) continue;
    moving_bodies_.push_back(b);
    Sphere& s = body_sphere_[static_cast<size_t>(b)];
    const std::vector<int>& gs = geoms_of[static_cast<size_t>(b)];
    for (int g : gs)
      for (int k = 0; k < 3; ++k) s.center[k] += m->geom_pos[3 * g + k] / static_cast<double>(gs.size());
    for (int g : gs)
      s.radius = m->geom_rbound[g] > 0
                     ? std::max(s.radius, distance(s.center, m->geom_pos + 3 * g) + m->geom_rbound[g])
                     : std::numeric_limits<double>::infinity();
  }
}

bool ArmContactScreen::clear(const mjModel* m, const mjData* d, Touch* touch) const {
  if (!screens_) return false;
  // The bodies' spheres in the world, this state.
  thread_local std::vector<std::array<double, 3>> center;
  center.resize(static_cast<size_t>(m->nbody));
  for (int b : moving_bodies_) {
    const Sphere& s = body_sphere_[static_cast<size_t>(b)];
    const mjtNum* x = d->xpos + 3 * b;
    const mjtNum* R = d->xmat + 9 * b;
    for (int r = 0; r < 3; ++r)
      center[static_cast<size_t>(b)][static_cast<size_t>(r)] =
          x[r] + R[3 * r] * s.center[0] + R[3 * r + 1] * s.center[1] + R[3 * r + 2] * s.center[2];
  }
  std::array<mjContact, mjMAXCONPAIR> con;
  for (const BodyPair& bp : body_pairs_) {
    const double* c = center[static_cast<size_t>(bp.body)].data();
    const double r = body_sphere_[static_cast<size_t>(bp.body)].radius;
    if (bp.other_geom < 0) {
      const double r2 = body_sphere_[static_cast<size_t>(bp.other_body)].radius;
      if (distance(c, center[static_cast<size_t>(bp.other_body)].data()) > r + r2 + margin_) continue;
    } else if (sphere_clear(m, d, bp.other_geom, c, r, margin_)) {
      continue;
    }
    for (const BodyPair::Row& row : bp.rows) {
      // The geom's bounding sphere against the other body's sphere, or the static geom's shape.
      const double* x = d->geom_xpos + 3 * row.geom;
      const double rb = m->geom_rbound[row.geom];
      if (rb > 0) {
        if (bp.other_geom >= 0 ? sphere_clear(m, d, bp.other_geom, x, rb, margin_)
                               : distance(x, center[static_cast<size_t>(bp.other_body)].data()) - rb -
                                         body_sphere_[static_cast<size_t>(bp.other_body)].radius >
                                     margin_)
          continue;
      }
      for (size_t k = row.first; k < row.end; ++k) {
        const GeomPair& p = bp.pairs[k];
        const double margin = pair_margin(m, p.g1, p.g2);
        const double rb1 = m->geom_rbound[p.g1], rb2 = m->geom_rbound[p.g2];
        if (rb1 > 0 && rb2 > 0 &&
            distance(d->geom_xpos + 3 * p.g1, d->geom_xpos + 3 * p.g2) > rb1 + rb2 + margin)
          continue;
        const int n = p.collide(m, d, con.data(), p.g1, p.g2, margin);
        for (int i = 0; i < n; ++i)
          if (!p.both_arm || con[static_cast<size_t>(i)].dist <= 0) {
            if (touch) *touch = p.g1_arm ? Touch{p.g1, p.g2} : Touch{p.g2, p.g1};
            return false;
          }
      }
    }
  }
  return true;
}

}  // namespace weldtwin
