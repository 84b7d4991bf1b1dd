// Part meshes: PLY read by our reader exactly as the same mesh's STL (ascii, binary of both endians, polygons
// as fans), and meshes no part can be refused with one clear line naming the file: faces naming missing
// vertices, a size no part on a table has (millimetres read as metres, or metres as millimetres: say so), no
// face with an area, and formats the docs do not promise (mutated files had crashed Assimp or Embree, or
// eaten all memory).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "core/mesh_file.hpp"
#include "perception/mesh_io.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

const std::filesystem::path dir = std::filesystem::temp_directory_path() / "weldtwin_mesh_io_test";

template <class T>
void put(std::string& out, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// The mesh as PLY: its first two triangles as one quad when they share an edge the right way, the rest as
// triangles.
std::string ply_of(const Mesh& m, const std::string& format) {
  const bool ascii = format == "ascii", big = format == "binary_big_endian";
  std::string out = "ply\nformat " + format + " 1.0\ncomment written by mesh_io_test\nelement vertex " +
                    std::to_string(m.vertices.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                    std::to_string(m.faces.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3& v : m.vertices) {
    if (ascii) {
      out += std::to_string(static_cast<float>(v.x())) + " " + std::to_string(static_cast<float>(v.y())) +
             " " + std::to_string(static_cast<float>(v.z())) + "\n";
    } else {
      for (int k = 0; k < 3; ++k) put(out, static_cast<float>(v[k]), big);
    }
  }
  for (const Eigen::Vector3i& f : m.faces) {
    if (ascii) {
      out += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
    } else {
      put(out, static_cast<uint8_t>(3), big);
      for (int k = 0; k < 3; ++k) put(out, static_cast<int32_t>(f[k]), big);
    }
  }
  return out;
}

std::string binary_stl(const Mesh& m, double scale) {
  std::string out(80, ' ');
  put(out, static_cast<uint32_t>(m.faces.size()), false);
  for (const Eigen::Vector3i& f : m.faces) {
    for (int k = 0; k < 3; ++k) put(out, 0.0f, false);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k)
        put(out, static_cast<float>(scale * m.vertices[static_cast<size_t>(f[c])][k]), false);
    out += std::string(2, '\0');
  }
  return out;
}

std::string write(const std::string& name, const std::string& bytes) {
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

void expect_refused(const std::string& path, const std::string& says, double scale = 1.0) {
  try {
    load_mesh(path, scale);
    ADD_FAILURE() << path << " was loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(std::filesystem::path(path).filename().string()), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
  }
}

TEST(MeshIo, PlyReadsAsItsStl) {
  const Mesh stl = load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
  for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    const Mesh ply = load_mesh(write(std::string("part_") + format + ".ply", ply_of(stl, format)));
    ASSERT_EQ(ply.vertices.size(), stl.vertices.size()) << format;
    ASSERT_EQ(ply.faces.size(), stl.faces.size()) << format;
    for (size_t i = 0; i < stl.faces.size(); ++i) {
      ASSERT_EQ(ply.faces[i], stl.faces[i]) << format << " face " << i;
      for (int c = 0; c < 3; ++c)
        EXPECT_LT((ply.vertices[static_cast<size_t>(ply.faces[i][c])] -
                   stl.vertices[static_cast<size_t>(stl.faces[i][c])])
                      .norm(),
                  1e-6)
            << format;
    }
  }
  // A quad and a pentagon become fans of triangles.
  const Mesh poly =
      load_mesh(write("poly.ply",
                      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                      "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 1.5 0\n4 0 1 2 3\n5 0 1 2 4 3\n"));
  ASSERT_EQ(poly.faces.size(), 5u);
  EXPECT_EQ(poly.faces[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(poly.faces[4], Eigen::Vector3i(0, 4, 3));
}

TEST(MeshIo, ObjReadsAsItsStl) {
  const Mesh stl = load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
  std::string obj = "# written by mesh_io_test\no part\n";
  for (const Vec3& v : stl.vertices)
    obj += "v " + std::to_string(v.x()) + " " + std::to_string(v.y()) + " " + std::to_string(v.z()) + "\n";
  for (size_t i = 0; i < stl.faces.size(); ++i) {
    const Eigen::Vector3i& f = stl.faces[i];
    // Every other face as vertex/texture/normal triples, one with indices counted from the end.
    if (i % 2)
      obj += "f " + std::to_string(f[0] + 1) + "/1/1 " + std::to_string(f[1] + 1) + "//2 " +
             std::to_string(f[2] + 1) + "/3\n";
    else
      obj += "f " + std::to_string(f[0] - static_cast<int>(stl.vertices.size())) + " " +
             std::to_string(f[1] + 1) + " " + std::to_string(f[2] + 1) + "\n";
  }
  const Mesh read = load_mesh(write("part.obj", obj));
  ASSERT_EQ(read.faces.size(), stl.faces.size());
  for (size_t i = 0; i < stl.faces.size(); ++i) ASSERT_EQ(read.faces[i], stl.faces[i]) << i;
  EXPECT_LT((read.vertices[7] - stl.vertices[7]).norm(), 1e-6);
  expect_refused(write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "face names vertex '9' of 3");
  expect_refused(write("short.obj", "v 0 0 0\nv 1 0\n"), "a vertex needs x y z");
}

TEST(MeshIo, MeshesNoPartCanBeAreRefusedNamingTheFile) {
  const Mesh stl = load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n0.1 0 0\n0 0.1 0\n";
  expect_refused(write("oob.ply", head + "3 0 1 999999\n"), "names vertex 999999");
  expect_refused(write("negative.ply", head + "3 0 -1 2\n"), "names vertex -1");
  expect_refused(write("huge_index.ply", head + "3 0 1 2.2e51\n"), "names vertex 2.2e+51");  // fuzzer's
  // The part in millimetres read as metres: 160 m across. With --units mm it loads.
  const std::string mm = write("in_mm.stl", binary_stl(stl, 1000.0));
  expect_refused(mm, "millimetres? use --units mm");
  EXPECT_EQ(load_mesh(mm, 1e-3).faces.size(), stl.faces.size());
  // The part in metres read as millimetres: 0.16 mm across (it had thrown an internal error making the
  // model: no surface sample, its height -1e9).
  const std::string metres = write("in_m.stl", binary_stl(stl, 1.0));
  expect_refused(metres, "mm across: too small for a part (read as millimetres: metres?", 1e-3);
  expect_refused(write("speck.stl", binary_stl(stl, 1e-3)), "mm across: too small for a part");
  // One vertex finite but absurd (it had stopped Embree on an assertion).
  Mesh huge = stl;
  huge.vertices[huge.faces[0][0]] = Vec3(8.6e36, 0, 0);
  expect_refused(write("huge.stl", binary_stl(huge, 1.0)), "m across");
  // A corner not a number, binary and ASCII: refused as read (the corners are joined by position).
  Mesh nan = stl;
  nan.vertices[nan.faces[3][1]] = Vec3(0.01, std::nan(""), 0.02);
  expect_refused(write("nan.stl", binary_stl(nan, 1.0)), "mesh has a non-finite vertex");
  expect_refused(write("nan_ascii.stl",
                       "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.1 0 0\n"
                       "vertex 0 nan 0\nendloop\nendfacet\nendsolid s\n"),
                 "mesh has a non-finite vertex");
  // Every face without an area.
  Mesh flat = stl;
  for (Vec3& v : flat.vertices) v = Vec3(0.1, 0.2, 0.3);
  expect_refused(write("degenerate.stl", binary_stl(flat, 1.0)), "no triangles with an area");
  expect_refused(write("part.gltf", "{\"asset\": {\"version\": \"2.0\"}}"), "unknown mesh format");
  // A malformed ascii STL: the reason is one short line, not the file pasted into it.
  std::string junk = "solid junk\n";
  for (int i = 0; i < 400; ++i) junk += "facet normal 0 0 1 outer loop vertex 1 2 x\n";
  try {
    load_mesh(write("junk.stl", junk));
    ADD_FAILURE() << "junk.stl was loaded";
  } catch (const InputError& e) {
    EXPECT_LT(std::string(e.what()).size(), 400u) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
}

// Our STL reader gives the mesh Assimp gives (the reader before it; Assimp stays for COLLADA): the same
// vertices, joined the same way, the same faces. The project's parts, the vendor's robot meshes (binary
// files whose header begins with "solid"), faces without a normal in the file, and ASCII with two solids.
TEST(MeshIo, StlReadsAsAssimpReadsIt) {
  auto same = [](const std::string& path, double float_ulps) {
    SCOPED_TRACE(path);
    const Mesh ours = load_mesh(path);
    const Mesh theirs = read_with_assimp(path, 1.0);
    ASSERT_EQ(ours.vertices.size(), theirs.vertices.size());
    ASSERT_EQ(ours.faces.size(), theirs.faces.size());
    for (size_t i = 0; i < ours.faces.size(); ++i) ASSERT_EQ(ours.faces[i], theirs.faces[i]) << i;
    for (size_t i = 0; i < ours.vertices.size(); ++i)
      ASSERT_LE((ours.vertices[i] - theirs.vertices[i]).cwiseAbs().maxCoeff(),
                float_ulps * 1.2e-7 * std::max(1.0, theirs.vertices[i].cwiseAbs().maxCoeff()))
          << i;
  };
  for (const char* part : {"tube_on_plate", "round_on_plate", "tube_tee", "offset_tube_on_plate",
                           "rect_tee_flat", "paper_tee", "cal_box"})
    same(test::repo(std::string("scenes/parts/") + part + ".stl"), 0.0);
  for (int link = 0; link <= 6; ++link)
    same(test::repo("scenes/robots/aubo_description/meshes/aubo_i5/collision/link" + std::to_string(link) +
                    ".STL"),
         0.0);
  const Mesh stl = load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
  same(write("no_normals.stl", binary_stl(stl, 1.0)), 0.0);  // every face's normal 0 0 0
  std::string ascii;
  for (int solid = 0; solid < 2; ++solid) {
    ascii += "solid part" + std::to_string(solid) + "\n";
    for (const Eigen::Vector3i& f : stl.faces) {
      const Vec3 &a = stl.vertices[static_cast<size_t>(f[0])], &b = stl.vertices[static_cast<size_t>(f[1])],
                 &c = stl.vertices[static_cast<size_t>(f[2])];
      const Vec3 n = (b - a).cross(c - a).normalized() + Vec3::Constant(0.1 * solid);
      char line[200];
      std::snprintf(line, sizeof line, " facet normal %.6e %.6e %.6e\n  outer loop\n", n.x(), n.y(), n.z());
      ascii += line;
      for (const Vec3* v : {&a, &b, &c}) {
        std::snprintf(line, sizeof line, "   vertex %.7g %.7g %.7g\n", v->x() + solid, v->y(), v->z());
        ascii += line;
      }
      ascii += "  endloop\n endfacet\n";
    }
    ascii += "endsolid part" + std::to_string(solid) + "\n";
  }
  same(write("two_solids.stl", ascii), 1.0);  // Assimp's own decimal parsing may round the last bit otherwise
}

// A robot's COLLADA visual mesh lies where its STL collision mesh lies (the vendor's upper arm: the file's
// Z_UP kept, not turned to Y-up), while a part mesh as COLLADA is still refused.
TEST(MeshIo, RobotColladaMeshLiesOnItsCollisionMesh) {
  const std::string meshes = test::repo("scenes/robots/aubo_description/meshes/aubo_i5/");
  const Mesh visual = load_robot_mesh(meshes + "visual/link2.DAE");
  const Mesh collision = load_robot_mesh(meshes + "collision/link2.STL");
  auto box = [](const Mesh& m) {
    Eigen::AlignedBox3d b;
    for (const Vec3& v : m.vertices) b.extend(v);
    return b;
  };
  const Eigen::AlignedBox3d a = box(visual), b = box(collision);
  EXPECT_GT(visual.faces.size(), 1000u);
  EXPECT_LT((a.min() - b.min()).cwiseAbs().maxCoeff(), 0.005)
      << a.min().transpose() << " / " << b.min().transpose();
  EXPECT_LT((a.max() - b.max()).cwiseAbs().maxCoeff(), 0.005)
      << a.max().transpose() << " / " << b.max().transpose();
  EXPECT_THROW(load_mesh(meshes + "visual/link2.DAE"), InputError);
}

}  // namespace
}  // namespace weldtwin
