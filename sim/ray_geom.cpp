#include "sim/ray_geom.hpp"

#include <cmath>
#include <limits>

namespace weldtwin::raygeom {
namespace {

// Keeps the smaller admissible root of a*t^2 + 2*b*t + c = 0.
double smallest_root(double a, double b, double c, double t_min) {
  if (a <= 0.0) return -1.0;
  const double disc = b * b - a * c;
  if (disc < 0.0) return -1.0;
  const double s = std::sqrt(disc);
  // Numerically stable pair of roots.
  const double q = b >= 0.0 ? -(b + s) : -(b - s);
  double t0 = q / a, t1 = q != 0.0 ? c / q : t0;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 >= t_min) return t0;
  if (t1 >= t_min) return t1;
  return -1.0;
}

void keep(double t, const Vec3& n, double& best, Vec3& best_n) {
  if (t >= 0.0 && (best < 0.0 || t < best)) {
    best = t;
    best_n = n;
  }
}

}  // namespace

double plane(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal) {
  if (d.z() >= 0.0 || o.z() < 0.0) return -1.0;  // one-sided: only rays coming down onto the +z face
  const double t = -o.z() / d.z();
  if (t < t_min) return -1.0;
  const Vec3 p = o + t * d;
  if ((size[0] > 0.0 && std::abs(p.x()) > size[0]) || (size[1] > 0.0 && std::abs(p.y()) > size[1]))
    return -1.0;
  if (normal) *normal = Vec3::UnitZ();
  return t;
}

double sphere(const Vec3& o, const Vec3& d, double radius, double t_min, Vec3* normal) {
  const double t = smallest_root(d.dot(d), o.dot(d), o.dot(o) - radius * radius, t_min);
  if (t >= 0.0 && normal) *normal = (o + t * d).normalized();
  return t;
}

double ellipsoid(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal) {
  const Vec3 s(size[0], size[1], size[2]);
  const Vec3 os = o.cwiseQuotient(s), ds = d.cwiseQuotient(s);
  const double t = smallest_root(ds.dot(ds), os.dot(ds), os.dot(os) - 1.0, t_min);
  if (t >= 0.0 && normal) *normal = (o + t * d).cwiseQuotient(s.cwiseProduct(s)).normalized();
  return t;
}

double cylinder(const Vec3& o, const Vec3& d, double radius, double half_length, double t_min, Vec3* normal) {
  double best = -1.0;
  Vec3 best_n = Vec3::Zero();
  // Side: x^2 + y^2 = r^2 with |z| <= h; both roots, the cylinder may be entered through a cap.
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 0.0) {
    const double b = o.x() * d.x() + o.y() * d.y();
    const double c = o.x() * o.x() + o.y() * o.y() - radius * radius;
    const double disc = b * b - a * c;
    if (disc >= 0.0) {
      const double s = std::sqrt(disc);
      for (double t : {(-b - s) / a, (-b + s) / a}) {
        if (t < t_min) continue;
        const Vec3 p = o + t * d;
        if (std::abs(p.z()) <= half_length) keep(t, Vec3(p.x(), p.y(), 0.0).normalized(), best, best_n);
      }
    }
  }
  // Caps: z = +-h with x^2 + y^2 <= r^2.
  if (d.z() != 0.0) {
    for (double side : {-1.0, 1.0}) {
      const double t = (side * half_length - o.z()) / d.z();
      if (t < t_min) continue;
      const Vec3 p = o + t * d;
      if (p.x() * p.x() + p.y() * p.y() <= radius * radius) keep(t, Vec3(0, 0, side), best, best_n);
    }
  }
  if (best >= 0.0 && normal) *normal = best_n;
  return best;
}

double capsule(const Vec3& o, const Vec3& d, double radius, double half_length, double t_min, Vec3* normal) {
  double best = -1.0;
  Vec3 best_n = Vec3::Zero();
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 0.0) {
    const double b = o.x() * d.x() + o.y() * d.y();
    const double c = o.x() * o.x() + o.y() * o.y() - radius * radius;
    const double disc = b * b - a * c;
    if (disc >= 0.0) {
      const double s = std::sqrt(disc);
      for (double t : {(-b - s) / a, (-b + s) / a}) {
        if (t < t_min) continue;
        const Vec3 p = o + t * d;
        if (std::abs(p.z()) <= half_length) keep(t, Vec3(p.x(), p.y(), 0.0).normalized(), best, best_n);
      }
    }
  }
  for (double side : {-1.0, 1.0}) {
    const Vec3 centre(0, 0, side * half_length);
    const Vec3 oc = o - centre;
    const double dd = d.dot(d), b = oc.dot(d), c = oc.dot(oc) - radius * radius;
    const double disc = b * b - dd * c;
    if (disc < 0.0) continue;
    const double s = std::sqrt(disc);
    for (double t : {(-b - s) / dd, (-b + s) / dd}) {
      if (t < t_min) continue;
      const Vec3 p = o + t * d;
      if (side * p.z() >= half_length) keep(t, (p - centre).normalized(), best, best_n);
    }
  }
  if (best >= 0.0 && normal) *normal = best_n;
  return best;
}

double box(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal) {
  // Slab method; entering and leaving faces tracked for the normal.
  double t_in = -std::numeric_limits<double>::infinity(), t_out = std::numeric_limits<double>::infinity();
  int in_axis = -1, out_axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (std::abs(o[k]) > size[k]) return -1.0;
      continue;
    }
    double t0 = (-size[k] - o[k]) / d[k], t1 = (size[k] - o[k]) / d[k];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_in) {
      t_in = t0;
      in_axis = k;
    }
    if (t1 < t_out) {
      t_out = t1;
      out_axis = k;
    }
  }
  if (t_in > t_out) return -1.0;
  double t = t_in;
  int axis = in_axis;
  if (t < t_min) {
    t = t_out;
    axis = out_axis;
  }
  if (t < t_min || axis < 0) return -1.0;
  if (normal) {
    *normal = Vec3::Zero();
    (*normal)[axis] = (o[axis] + t * d[axis]) > 0.0 ? 1.0 : -1.0;
  }
  return t;
}

double triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c, double t_min,
                Vec3* normal) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-300) return -1.0;
  const double inv = 1.0 / det;
  const Vec3 s = o - a;
  const double u = s.dot(p) * inv;
  if (u < 0.0 || u > 1.0) return -1.0;
  const Vec3 q = s.cross(e1);
  const double v = d.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0) return -1.0;
  const double t = e2.dot(q) * inv;
  if (t < t_min) return -1.0;
  if (normal) *normal = e1.cross(e2).normalized();
  return t;
}

}  // namespace weldtwin::raygeom
