// Rays and point queries against a mesh, on a cube whose answers are known in closed form: distances exact,
// inside/outside right everywhere — also where the rays of the parity test pass exactly through the cube's
// edges and corners (a single ray's parity flips there when it slips between two triangles).
#include "perception/mesh_rays.hpp"

#include <gtest/gtest.h>

#include <random>

#include "tests/support/test_meshes.hpp"

namespace weldtwin {
namespace {

using test::cube_mesh;

double cube_distance(const Vec3& p, double h) {
  const Vec3 out = (p.cwiseAbs().array() - h).matrix();
  if ((out.array() <= 0).all()) return -out.maxCoeff();  // inside: to the nearest face
  return out.cwiseMax(0.0).norm();
}

TEST(MeshRays, DistanceAndInsideMatchTheCubeEverywhere) {
  const double h = 0.05;
  const MeshRays rays(cube_mesh(h));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  for (int k = 0; k < 20000; ++k) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const bool in = (p.cwiseAbs().array() < h).all();
    if (std::abs(p.cwiseAbs().maxCoeff() - h) < 1e-6) continue;  // on the surface: either answer
    EXPECT_EQ(rays.inside(p), in) << p.transpose();
    EXPECT_NEAR(rays.distance(p, 1.0), cube_distance(p, h), 1e-6) << p.transpose();
  }
  EXPECT_TRUE(std::isinf(rays.distance(Vec3(0.5, 0, 0), 0.1))) << "nothing within the range";
}

TEST(MeshRays, InsideIsRightWhereRaysMeetEdgesAndCorners) {
  const double h = 0.05;
  const MeshRays rays(cube_mesh(h));
  // Points from which a ray in any of many directions runs exactly through a corner or an edge's middle.
  std::vector<Vec3> targets;
  for (int i = 0; i < 8; ++i) targets.emplace_back(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h);
  for (int a = 0; a < 3; ++a)
    for (double s1 : {-h, h})
      for (double s2 : {-h, h}) {
        Vec3 e = Vec3::Zero();
        e[(a + 1) % 3] = s1;
        e[(a + 2) % 3] = s2;
        targets.push_back(e);
      }
  const Vec3 dirs[] = {Vec3(0.1234, 0.2345, 0.9642).normalized(), Vec3(-0.8311, 0.3127, -0.4597).normalized(),
                       Vec3(0.3719, -0.9013, 0.2221).normalized(), Vec3(1, 1, 1).normalized()};
  int checked = 0;
  for (const Vec3& target : targets)
    for (const Vec3& d : dirs)
      for (double t : {0.01, 0.023, 0.037, 0.06, 0.09}) {
        const Vec3 p = target - t * d;
        if (std::abs(p.cwiseAbs().maxCoeff() - h) < 1e-6) continue;
        const bool in = (p.cwiseAbs().array() < h).all();
        EXPECT_EQ(rays.inside(p), in) << p.transpose() << " towards " << target.transpose();
        ++checked;
      }
  EXPECT_GT(checked, 300);
}

}  // namespace
}  // namespace weldtwin
