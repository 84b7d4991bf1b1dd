#include "perception/mesh_io.hpp"

#include <cmath>
#include <random>

#include "core/error.hpp"
#include "perception/mesh_rays.hpp"

namespace weldtwin {

SurfaceSamples sample_surface(const Mesh& mesh, double spacing_m, double min_normal_z) {
  SurfaceSamples out;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double per_area = 1.0 / (spacing_m * spacing_m);
  for (const auto& f : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec3 cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    if (area < 1e-14) continue;
    const Vec3 n = cross.normalized();
    if (n.z() < min_normal_z) continue;
    // Expected count area * density, the fraction drawn at random so small faces are not lost.
    const double expected = area * per_area;
    int count = static_cast<int>(expected);
    if (u(rng) < expected - count) ++count;
    for (int k = 0; k < count; ++k) {
      double r1 = u(rng), r2 = u(rng);
      if (r1 + r2 > 1.0) {
        r1 = 1.0 - r1;
        r2 = 1.0 - r2;
      }
      out.points.push_back(a + r1 * (b - a) + r2 * (c - a));
      out.normals.push_back(n);
    }
  }
  return out;
}

}  // namespace weldtwin

namespace weldtwin {

int orient_outward(Mesh& mesh) {
  const MeshRays rays(mesh);
  auto crossings = [&](const Vec3& o, const Vec3& d) {
    int n = 0;
    for (double t = 1e-6; n < 64;) {
      const double hit = rays.hit(o, d, t);
      if (!std::isfinite(hit)) break;
      ++n;
      t = hit + 1e-6;
    }
    return n;
  };
  int turned = 0;
  for (auto& f : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec3 cross = (b - a).cross(c - a);
    if (cross.norm() < 1e-14) continue;
    const Vec3 n = cross.normalized(), centre = (a + b + c) / 3.0;
    const Vec3 u = (b - a).normalized(), v = n.cross(u);
    int odd = 0;
    for (const Vec3& d : {n, (n + 0.35 * u).normalized(), (n + 0.35 * v).normalized()})
      odd += crossings(centre, d) % 2;
    if (odd >= 2) {
      std::swap(f[1], f[2]);
      ++turned;
    }
  }
  return turned;
}

namespace {

std::vector<Vec3> test_directions(const Vec3& n) {
  // Horizontal part of the normal, to tilt up from.
  Vec3 h = n - n.z() * Vec3::UnitZ();
  std::vector<Vec3> dirs{n};
  if (h.norm() > 1e-6) {
    h.normalize();
    for (double up : {kPi / 6, kPi / 3}) dirs.push_back(std::cos(up) * h + std::sin(up) * Vec3::UnitZ());
  }
  if (n.z() > -0.1) dirs.push_back(Vec3::UnitZ());
  return dirs;
}

}  // namespace

int view_directions(const MeshRays& rays, const Vec3& point, const Vec3& n) {
  int count = 0;
  for (const Vec3& d : test_directions(n))
    count += d.dot(n) > 0.0 && !std::isfinite(rays.hit(point, d.normalized()));
  return count;
}

}  // namespace weldtwin
