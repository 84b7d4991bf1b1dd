#include "sim/contact_prefilter.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <vector>

// MuJoCo's table of pair-wise collision functions, indexed by the two geom types (the smaller first).
// Exported by libmujoco (MJAPI in its collision driver) though not declared in the public headers.
extern "C" mjfCollision mjCOLLISIONFUNC[mjNGEOMTYPES][mjNGEOMTYPES];

namespace weldtwin {
namespace {

// Slack on every "apart" decision, far above the rounding of the tests (metres): a pair closer than
// margin + kSlack always goes to MuJoCo.
constexpr double kSlack = 1e-6;

struct Frame {
  double c[3];      // centre, world
  double ax[3][3];  // ax[k]: the geom's local axis k in world
  double half[3];   // half sizes along the axes (a cylinder's box: radius, radius, half-length)
};

// The box round a mesh's vertices in its frame, computed once per thread and mesh id: the entry is trusted
// only while the vertices' address, count and first and last vertex match (another model may have other
// meshes under the same ids, or later take the same memory).
struct MeshBox {
  const float* vert = nullptr;
  int count = 0;
  float first[3] = {0, 0, 0}, last[3] = {0, 0, 0};
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
};

const MeshBox& mesh_box(int mesh, const float* v, int count) {
  thread_local std::vector<MeshBox>
      boxes;  // by mesh id (a vector: hashing the address cost as much as the test)
  if (static_cast<size_t>(mesh) >= boxes.size()) boxes.resize(static_cast<size_t>(mesh) + 1);
  MeshBox& box = boxes[static_cast<size_t>(mesh)];
  if (count <= 0) {
    box = MeshBox();
    return box;
  }
  const float* end = v + 3 * (count - 1);
  if (box.vert == v && box.count == count && std::equal(v, v + 3, box.first) &&
      std::equal(end, end + 3, box.last))
    return box;
  box = MeshBox();
  box.vert = v;
  box.count = count;
  std::copy(v, v + 3, box.first);
  std::copy(end, end + 3, box.last);
  for (int i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k)
      box.lo[k] = std::min(box.lo[k], double(v[3 * i + k])),
      box.hi[k] = std::max(box.hi[k], double(v[3 * i + k]));
  return box;
}

Frame frame_of(const mjModel* m, const mjData* d, int g) {
  Frame f;
  const mjtNum* x = d->geom_xmat + 9 * g;
  for (int r = 0; r < 3; ++r) f.c[r] = d->geom_xpos[3 * g + r];
  for (int k = 0; k < 3; ++k)
    for (int r = 0; r < 3; ++r) f.ax[k][r] = x[3 * r + k];  // row-major: column k is axis k
  const mjtNum* s = m->geom_size + 3 * g;
  if (m->geom_type[g] == mjGEOM_MESH) {
    // The box round the mesh's vertices in the geom frame (MuJoCo keeps them so), its centre off the origin.
    const int mesh = m->geom_dataid[g];
    const MeshBox& box = mesh_box(mesh, m->mesh_vert + 3 * m->mesh_vertadr[mesh], m->mesh_vertnum[mesh]);
    const double *lo = box.lo, *hi = box.hi;
    for (int k = 0; k < 3; ++k) {
      f.half[k] = 0.5 * (hi[k] - lo[k]) + 1e-7;  // float vertices
      const double mid = 0.5 * (hi[k] + lo[k]);
      for (int r = 0; r < 3; ++r) f.c[r] += mid * f.ax[k][r];
    }
  } else if (m->geom_type[g] == mjGEOM_CYLINDER) {
    f.half[0] = f.half[1] = s[0];
    f.half[2] = s[1];
  } else {
    f.half[0] = s[0], f.half[1] = s[1], f.half[2] = s[2];
  }
  return f;
}

double dot(const double* a, const double* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// The shortest distance between segments p0 + s (p1 - p0) and q0 + t (q1 - q0), s, t in [0, 1].
double segment_distance(const double* p0, const double* p1, const double* q0, const double* q1) {
  double d1[3], d2[3], r[3];
  for (int i = 0; i < 3; ++i) d1[i] = p1[i] - p0[i], d2[i] = q1[i] - q0[i], r[i] = p0[i] - q0[i];
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  double s = 0.0, t = 0.0;
  constexpr double kTiny = 1e-18;
  if (a <= kTiny && e <= kTiny) {
    s = t = 0.0;
  } else if (a <= kTiny) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = dot(d1, r);
    if (e <= kTiny) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      // The nearest points of the two lines, s clamped, then t for that s clamped and s again for that t.
      const double b = dot(d1, d2), denom = a * e - b * b;
      s = denom > 0.0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  double w[3];
  for (int i = 0; i < 3; ++i) w[i] = r[i] + s * d1[i] - t * d2[i];
  return std::sqrt(dot(w, w));
}

// Separating-axis test of two boxes: the 3 + 3 face normals and the 9 edge-pair directions.
bool separated(const Frame& A, const Frame& B, double margin) {
  double R[3][3], absR[3][3], T[3], d[3];
  for (int i = 0; i < 3; ++i) d[i] = B.c[i] - A.c[i];
  for (int i = 0; i < 3; ++i) {
    T[i] = dot(d, A.ax[i]);
    for (int j = 0; j < 3; ++j) {
      R[i][j] = dot(A.ax[i], B.ax[j]);
      absR[i][j] = std::abs(R[i][j]) + 1e-12;  // near-parallel edges: their cross products are no axis
    }
  }
  const double gap = margin + kSlack;
  for (int i = 0; i < 3; ++i) {
    const double ra = A.half[i],
                 rb = B.half[0] * absR[i][0] + B.half[1] * absR[i][1] + B.half[2] * absR[i][2];
    if (std::abs(T[i]) > ra + rb + gap) return true;
  }
  for (int j = 0; j < 3; ++j) {
    const double ra = A.half[0] * absR[0][j] + A.half[1] * absR[1][j] + A.half[2] * absR[2][j];
    const double t = T[0] * R[0][j] + T[1] * R[1][j] + T[2] * R[2][j];
    if (std::abs(t) > ra + B.half[j] + gap) return true;
  }
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      // Axis A_i x B_j, of length sqrt(1 - R_ij^2): the margin scales with it.
      const double len = std::sqrt(std::max(0.0, 1.0 - R[i][j] * R[i][j]));
      if (len < 1e-6) continue;
      const double ra = A.half[i1] * absR[i2][j] + A.half[i2] * absR[i1][j];
      const double rb = B.half[j1] * absR[i][j2] + B.half[j2] * absR[i][j1];
      const double t = T[i2] * R[i1][j] - T[i1] * R[i2][j];
      if (std::abs(t) > ra + rb + gap * len) return true;
    }
  }
  return false;
}

// MuJoCo's own functions for the pairs given an early-out, saved before the table is changed.
mjfCollision mujoco_function[mjNGEOMTYPES][mjNGEOMTYPES] = {};

mjfCollision original(const mjModel* m, int g1, int g2) {
  return mujoco_function[m->geom_type[g1]][m->geom_type[g2]];
}

int cylinder_cylinder(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  if (cylinder_capsule_gap(m, d, g1, g2) > margin + kSlack || boxes_separated(m, d, g1, g2, margin)) return 0;
  return original(m, g1, g2)(m, d, con, g1, g2, margin);
}

// Cylinder-box, and a mesh (the convex pieces of the arm's links) against a cylinder, a box or a mesh.
int boxed_pair(const mjModel* m, const mjData* d, mjContact* con, int g1, int g2, mjtNum margin) {
  if (boxes_separated(m, d, g1, g2, margin)) return 0;
  return original(m, g1, g2)(m, d, con, g1, g2, margin);
}

struct Pair {
  int type1, type2;
  mjfCollision early_out;
};
constexpr Pair kPairs[] = {{mjGEOM_CYLINDER, mjGEOM_CYLINDER, cylinder_cylinder},
                           {mjGEOM_CYLINDER, mjGEOM_BOX, boxed_pair},
                           {mjGEOM_CYLINDER, mjGEOM_MESH, boxed_pair},
                           {mjGEOM_BOX, mjGEOM_MESH, boxed_pair},
                           {mjGEOM_MESH, mjGEOM_MESH, boxed_pair}};

// MuJoCo's table entries for the pairs: the early-outs (on) or its own functions.
void point_table(bool on) {
  for (const Pair& p : kPairs)
    if (mujoco_function[p.type1][p.type2])
      mjCOLLISIONFUNC[p.type1][p.type2] = on ? p.early_out : mujoco_function[p.type1][p.type2];
}

}  // namespace

double cylinder_capsule_gap(const mjModel* m, const mjData* d, int g1, int g2) {
  double end[2][2][3];
  const int g[2] = {g1, g2};
  for (int k = 0; k < 2; ++k) {
    const mjtNum* x = d->geom_xmat + 9 * g[k];
    const double h = m->geom_size[3 * g[k] + 1];
    for (int r = 0; r < 3; ++r) {
      end[k][0][r] = d->geom_xpos[3 * g[k] + r] - h * x[3 * r + 2];
      end[k][1][r] = d->geom_xpos[3 * g[k] + r] + h * x[3 * r + 2];
    }
  }
  return segment_distance(end[0][0], end[0][1], end[1][0], end[1][1]) - m->geom_size[3 * g1] -
         m->geom_size[3 * g2];
}

bool boxes_separated(const mjModel* m, const mjData* d, int g1, int g2, double margin) {
  return separated(frame_of(m, d, g1), frame_of(m, d, g2), margin);
}

void enable_contact_prefilter(bool on) {
  install_contact_prefilter();
  point_table(on);
}

mjfCollision prefiltered_collision_function(int type1, int type2) {
  install_contact_prefilter();
  return mjCOLLISIONFUNC[type1][type2];
}

mjfCollision mujoco_collision_function(int type1, int type2) {
  install_contact_prefilter();
  return mujoco_function[type1][type2] ? mujoco_function[type1][type2] : mjCOLLISIONFUNC[type1][type2];
}

void install_contact_prefilter() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (const Pair& p : kPairs) mujoco_function[p.type1][p.type2] = mjCOLLISIONFUNC[p.type1][p.type2];
    point_table(true);
  });
}

}  // namespace weldtwin
