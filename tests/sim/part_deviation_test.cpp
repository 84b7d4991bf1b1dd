// The part as it really is: extents off within their bound and still resting on the table, tack welds as
// closed cubes on the seams, the bend's sagitta as a circular arc of that angle has it.
#include "sim/part_deviation.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "perception/mesh_rays.hpp"

namespace weldtwin {
namespace {

// A 300 x 50 x 40 mm box resting on z = 0.
Mesh bar() {
  Mesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(k & 1 ? 0.15 : -0.15, k & 2 ? 0.025 : -0.025, k & 4 ? 0.04 : 0.0);
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) m.faces.emplace_back(t[0], t[1], t[2]);
  return m;
}

void box_of(const Mesh& m, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const Vec3& v : m.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
}

TEST(PartDeviation, NoDeviationIsTheCad) {
  const Mesh cad = bar();
  const DeviatedPart d = deviate_part(cad, {}, PartDeviationSetting(), 3);
  ASSERT_EQ(d.mesh.vertices.size(), cad.vertices.size());
  for (size_t i = 0; i < cad.vertices.size(); ++i) EXPECT_EQ(d.mesh.vertices[i], cad.vertices[i]);
}

TEST(PartDeviation, ExtentsStayWithinTheirBoundAndThePartOnTheTable) {
  PartDeviationSetting s;
  s.dimension_m = 0.001;
  bool changed = false;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const DeviatedPart d = deviate_part(bar(), {}, s, seed);
    Vec3 lo, hi;
    box_of(d.mesh, lo, hi);
    const Vec3 ext = hi - lo;
    EXPECT_NEAR(ext.x(), 0.30, 0.001 + 1e-12);
    EXPECT_NEAR(ext.y(), 0.05, 0.001 + 1e-12);
    EXPECT_NEAR(ext.z(), 0.04, 0.001 + 1e-12);
    EXPECT_NEAR(lo.z(), 0.0, 1e-12);
    changed = changed || std::abs(ext.x() - 0.30) > 1e-4;
  }
  EXPECT_TRUE(changed);
}

TEST(PartDeviation, TackWeldsAreClosedCubesOnTheSeams) {
  PartDeviationSetting s;
  s.tack_welds = 3;
  const std::vector<Vec3> seam{{-0.1, -0.025, 0.04}, {0.0, -0.025, 0.04}, {0.1, -0.025, 0.04}};
  const DeviatedPart d = deviate_part(bar(), seam, s, 5);
  ASSERT_EQ(d.tacks.size(), 3u);
  ASSERT_EQ(d.mesh.vertices.size(), 8u + 3 * 8);
  ASSERT_EQ(d.mesh.faces.size(), 12u + 3 * 12);
  const MeshRays rays(d.mesh);
  for (const Vec3& t : d.tacks) {
    bool on_seam = false;
    for (const Vec3& p : seam) on_seam = on_seam || (t - p).norm() < 1e-12;
    EXPECT_TRUE(on_seam);
    // Proud of the bar's top and side by half the cube's edge: a ray down onto the tack stops 3 mm early,
    // and the point just above the seam is inside the (closed, outward-wound) cube.
    const double drop = rays.hit(t + Vec3(0, -0.001, 0.1), Vec3(0, 0, -1));
    EXPECT_NEAR(drop, 0.1 - 0.5 * s.tack_edge_m, 1e-6);
    EXPECT_TRUE(rays.inside(t + Vec3(0, -0.001, 0.001)));
  }
}

TEST(PartDeviation, TheBendsSagittaIsThatOfACircularArcOfItsAngle) {
  PartDeviationSetting s;
  s.bend_deg = 1.0;
  const DeviatedPart d = deviate_part(bar(), {}, s, 11);
  ASSERT_GT(std::abs(d.bend_rad), 0.0);
  ASSERT_LE(std::abs(d.bend_rad), 1.0 * kPi / 180.0);
  EXPECT_EQ(d.bend_axis, 0);  // the bar's longest horizontal extent is x
  // An arc of angle theta over the chord L = 0.3 m: radius L / theta, sagitta R - sqrt(R^2 - (L / 2)^2).
  const double R = 0.3 / std::abs(d.bend_rad);
  const double sagitta = R - std::sqrt(R * R - 0.15 * 0.15);
  // The ends moved across by the sagitta relative to the middle (the bar's middle is its vertices' x = 0
  // line, which is not a vertex: compare the ends with the undeformed y).
  const Mesh cad = bar();
  for (size_t i = 0; i < cad.vertices.size(); ++i) {
    const double moved = d.mesh.vertices[i].y() - cad.vertices[i].y();
    EXPECT_NEAR(std::abs(moved), sagitta, 0.01 * sagitta) << i;
    EXPECT_GT(moved * d.bend_rad, 0.0);  // to the side the angle's sign says
  }
}

TEST(PartDeviation, ASeamMovesWithThePartsSurface) {
  // The seam along the bar's front top edge, its points 1 mm apart: on the deviated part it still lies on
  // that edge (between the edge's two deviated corners, bowed as the bend bows it), and stretches with x.
  PartDeviationSetting s;
  s.dimension_m = 0.001;
  s.bend_deg = 1.0;
  const DeviatedPart d = deviate_part(bar(), {}, s, 7);
  const Mesh cad = bar();
  const Vec3 a = d.mesh.vertices[4], b = d.mesh.vertices[5];  // the corners (-x, -y, top) and (+x, -y, top)
  EXPECT_LT((d.apply(cad.vertices[4]) - a).norm(), 1e-15);
  EXPECT_LT((d.apply(cad.vertices[5]) - b).norm(), 1e-15);
  for (double x = -0.15; x <= 0.15; x += 0.001) {
    const Vec3 p = d.apply(Vec3(x, -0.025, 0.04));
    EXPECT_NEAR(p.z(), a.z(), 1e-12);  // still on the top
    // Along the edge by the scale, the middle of the bar staying put ...
    EXPECT_NEAR(p.x(), x * d.scale.x(), 1e-12);
    // ... and across it by the bend's sagitta at that x: a parabola through both corners, level in the
    // middle.
    const double t = p.x() / (0.15 * d.scale.x());
    EXPECT_NEAR(p.y(), -0.025 * d.scale.y() + (a.y() + 0.025 * d.scale.y()) * t * t, 1e-9) << x;
  }
}

}  // namespace
}  // namespace weldtwin
