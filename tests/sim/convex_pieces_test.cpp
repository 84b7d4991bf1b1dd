// Convex pieces of a mesh: together they hold the whole mesh, and MuJoCo's hulls of them leave out what a
// single hull would fill in.
#include "sim/convex_pieces.hpp"

#include <gtest/gtest.h>

#include <iomanip>
#include <sstream>

#include "sim/mujoco_world.hpp"

namespace weldtwin {
namespace {

// A closed axis-aligned box as 8 vertices and 12 triangles, appended to `m`.
void add_box(Mesh& m, const Vec3& lo, const Vec3& hi) {
  const int base = static_cast<int>(m.vertices.size());
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.emplace_back(base + q[0], base + q[1], base + q[2]);
    m.faces.emplace_back(base + q[0], base + q[2], base + q[3]);
  }
}

// Two 100 mm blocks half a metre apart joined by a 20 mm bar: an upper arm's housings and tube, squared.
Mesh dumbbell() {
  Mesh m;
  add_box(m, Vec3(0, -0.05, -0.05), Vec3(0.1, 0.05, 0.05));
  add_box(m, Vec3(0.1, -0.01, -0.01), Vec3(0.4, 0.01, 0.01));
  add_box(m, Vec3(0.4, -0.05, -0.05), Vec3(0.5, 0.05, 0.05));
  return m;
}

// Contacts between a 4 mm sphere at `at` and meshes made of the given point sets (one hull each).
int contacts_with_hulls(const std::vector<std::vector<Vec3>>& hulls, const Vec3& at) {
  std::ostringstream xml;
  xml << std::setprecision(17) << "<mujoco><asset>\n";
  for (size_t h = 0; h < hulls.size(); ++h) {
    xml << "<mesh name=\"h" << h << "\" vertex=\"";
    for (const Vec3& p : hulls[h]) xml << p.x() << ' ' << p.y() << ' ' << p.z() << ' ';
    xml << "\"/>\n";
  }
  // The pieces on a free body (MuJoCo does not collide two geoms that are both fixed to the world).
  xml << "</asset><worldbody><geom name=\"probe\" type=\"sphere\" size=\"0.004\" pos=\"" << at.x() << ' '
      << at.y() << ' ' << at.z() << "\"/>\n<body name=\"link\"><freejoint/>\n";
  for (size_t h = 0; h < hulls.size(); ++h) xml << "<geom type=\"mesh\" mesh=\"h" << h << "\"/>\n";
  xml << "</body></worldbody></mujoco>\n";
  ModelPtr m = load_mjcf(xml.str(), "/tmp", "test");
  DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  mj_collision(m.get(), d.get());
  return d->ncon;
}

TEST(ConvexPieces, SlabsAcrossTheLongestSideNoThickerThanAsked) {
  const Mesh m = dumbbell();
  const auto pieces = convex_pieces(m, ConvexPiecesSetting{0.05});
  ASSERT_EQ(pieces.size(), 10u);
  for (const auto& piece : pieces) {
    double lo = 1e9, hi = -1e9;
    for (const Vec3& p : piece) lo = std::min(lo, p.x()), hi = std::max(hi, p.x());
    EXPECT_LE(hi - lo, 0.05 + 1e-9);
  }
}

TEST(ConvexPieces, EveryVertexOfTheMeshIsInAPiece) {
  const Mesh m = dumbbell();
  const auto pieces = convex_pieces(m, ConvexPiecesSetting{0.035});
  for (const Vec3& v : m.vertices) {
    double nearest = 1e9;
    for (const auto& piece : pieces)
      for (const Vec3& p : piece) nearest = std::min(nearest, (p - v).norm());
    EXPECT_LT(nearest, 1e-6) << v.transpose();
  }
}

TEST(ConvexPieces, MujocoCollidesThePiecesWhereTheMeshIsAndNotWhereOneHullFillsIn) {
  const Mesh m = dumbbell();
  const auto pieces = convex_pieces(m);
  const Vec3 above_bar(0.25, 0.0, 0.04);  // outside the mesh, inside its hull
  EXPECT_EQ(contacts_with_hulls(pieces, above_bar), 0);
  EXPECT_GT(contacts_with_hulls({m.vertices}, above_bar), 0) << "one hull fills the notch in";
  for (const Vec3& inside : {Vec3(0.05, 0, 0.048), Vec3(0.25, 0, 0.012), Vec3(0.45, 0.048, 0)})
    EXPECT_GT(contacts_with_hulls(pieces, inside), 0) << inside.transpose();
}

TEST(ConvexPieces, AFlatMeshHasNoPieces) {
  Mesh flat;
  flat.vertices = {Vec3(0, 0, 0), Vec3(0.2, 0, 0), Vec3(0.2, 0.1, 0), Vec3(0, 0.1, 0)};
  flat.faces = {Eigen::Vector3i(0, 1, 2), Eigen::Vector3i(0, 2, 3)};
  EXPECT_TRUE(convex_pieces(flat).empty());
  EXPECT_TRUE(convex_pieces(Mesh{}).empty());
}

}  // namespace
}  // namespace weldtwin
