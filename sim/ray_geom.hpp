// Exact ray intersections with MuJoCo's primitive geoms, in double precision, in the geom frame (MuJoCo's
// conventions: box/ellipsoid half-sizes, sphere radius, capsule/cylinder radius + half-length along z, plane
// z = 0 seen from +z only, bounded by its half-sizes unless they are 0). Each returns the smallest distance
// t >= t_min along the ray (dir need not be unit: t is in units of |dir|), or -1, and the outward normal.
#pragma once

#include "core/geometry.hpp"

namespace weldtwin::raygeom {

double plane(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal);
double sphere(const Vec3& o, const Vec3& d, double radius, double t_min, Vec3* normal);
double ellipsoid(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal);
double capsule(const Vec3& o, const Vec3& d, double radius, double half_length, double t_min, Vec3* normal);
double cylinder(const Vec3& o, const Vec3& d, double radius, double half_length, double t_min, Vec3* normal);
double box(const Vec3& o, const Vec3& d, const double size[3], double t_min, Vec3* normal);
/// One triangle (Moller-Trumbore), both faces.
double triangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c, double t_min,
                Vec3* normal);

}  // namespace weldtwin::raygeom
