#include "core/mesh_file.hpp"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/files.hpp"

namespace weldtwin {

namespace {

constexpr double kMaxPartSize = 5.0;       // no part on a welding table is larger [m]
constexpr double kMinPartSize = 0.002;     // nor smaller (a mesh in metres read as millimetres is 1/1000) [m]
constexpr double kDegenerateArea = 1e-14;  // a face with a smaller cross product has no area [m^2]

// What every mesh must be, whichever reader read it: finite, of a size a part can have, its faces naming its
// vertices, some of them with an area.
void check_mesh(const std::string& path, Mesh& mesh, double scale) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Vec3& v : mesh.vertices) {
    if (!v.allFinite()) throw input_error(path, "mesh has a non-finite vertex");
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  std::vector<Eigen::Vector3i> kept;
  const int n = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3i& f : mesh.faces) {
    if ((f.array() < 0).any() || (f.array() >= n).any())
      throw input_error(path, "mesh face names a vertex that does not exist");
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    if ((b - a).cross(c - a).norm() >= kDegenerateArea) kept.push_back(f);
  }
  if (kept.empty()) throw input_error(path, "mesh has no triangles with an area");
  mesh.faces = std::move(kept);
  const double size = (hi - lo).maxCoeff();
  if (size > kMaxPartSize) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "the mesh is %.3g m across%s", size,
                  scale == 1.0 && size < 1e4 ? ": millimetres? use --units mm" : ": not a part on a table");
    throw input_error(path, buf);
  }
  if (size < kMinPartSize) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "the mesh is %.3g mm across: too small for a part%s", 1e3 * size,
                  scale != 1.0 ? " (read as millimetres: metres? leave out --units mm)" : "");
    throw input_error(path, buf);
  }
}

// Wavefront OBJ: `v x y z` vertices and `f a b c ...` faces (indices from 1, negative from the end, each
// maybe `a/t/n`), polygons as fans; everything else ignored. Ours rather than Assimp's, which leaked on
// malformed files the fuzzer wrote.
Mesh read_obj(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw input_error(path, "cannot open the mesh");
  Mesh mesh;
  std::string line;
  size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "v") {
      Vec3 v;
      if (!(words >> v.x() >> v.y() >> v.z()))
        throw input_error(path, "line " + std::to_string(number) + ": a vertex needs x y z");
      mesh.vertices.push_back(v);
    } else if (key == "f") {
      std::vector<int> ids;
      for (std::string w; words >> w;) {
        long long i = 0;
        const auto r = std::from_chars(w.data(), w.data() + w.size(), i);
        const long long n = static_cast<long long>(mesh.vertices.size());
        if (r.ec != std::errc() || (r.ptr != w.data() + w.size() && *r.ptr != '/') || i == 0 || i > n ||
            i < -n)
          throw input_error(path, "line " + std::to_string(number) + ": face names vertex '" + w + "' of " +
                                      std::to_string(n));
        ids.push_back(static_cast<int>(i > 0 ? i - 1 : n + i));
      }
      if (ids.size() < 3)
        throw input_error(path, "line " + std::to_string(number) + ": a face needs 3 vertices");
      for (size_t k = 2; k < ids.size(); ++k) mesh.faces.emplace_back(ids[0], ids[k - 1], ids[k]);
    }
  }
  return mesh;
}

// STL, and the COLLADA files of robot descriptions, through Assimp: every node's meshes in the file's frame.
// A COLLADA file's up axis is not turned into Assimp's Y-up: URDFs place their meshes as the file has them.
Mesh read_with_assimp(const std::string& path, double scale, bool collada = false) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices;
  const aiScene* scene = importer.ReadFile(path, collada ? flags | aiProcess_PreTransformVertices : flags);
  if (!scene || !scene->mRootNode) {
    // Assimp's message may quote kilobytes of the file: one line, cut short.
    constexpr size_t kMaxReason = 160;
    std::string why = importer.GetErrorString();
    for (char& ch : why)
      if (ch == '\n' || ch == '\r' || ch == '\t') ch = ' ';
    if (why.size() > kMaxReason) why = why.substr(0, kMaxReason) + "...";
    throw input_error(path, "cannot read the mesh: " + why);
  }
  Mesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const int base = static_cast<int>(mesh.vertices.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      const Vec3 q = scale * Vec3(p.x, p.y, p.z);
      if (!q.allFinite()) throw input_error(path, "mesh has a non-finite vertex");
      mesh.vertices.push_back(q);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      if (face.mIndices[0] >= am->mNumVertices || face.mIndices[1] >= am->mNumVertices ||
          face.mIndices[2] >= am->mNumVertices)
        throw input_error(path, "mesh face names a vertex that does not exist");
      mesh.faces.emplace_back(base + static_cast<int>(face.mIndices[0]),
                              base + static_cast<int>(face.mIndices[1]),
                              base + static_cast<int>(face.mIndices[2]));
    }
  }
  if (mesh.faces.empty()) throw input_error(path, "mesh has no triangles");
  check_mesh(path, mesh, scale);
  return mesh;
}

}  // namespace

void write_stl(const Mesh& mesh, const std::string& path, const std::string& header) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw input_error(path, "cannot be written");
  char head[80] = {};
  header.copy(head, sizeof head - 1);
  out.write(head, sizeof head);
  const uint32_t n = static_cast<uint32_t>(mesh.faces.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  for (const Eigen::Vector3i& f : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec3 normal = (b - a).cross(c - a).normalized();
    float record[12];
    for (int k = 0; k < 3; ++k) {
      record[k] = static_cast<float>(normal[k]);
      record[3 + k] = static_cast<float>(a[k]);
      record[6 + k] = static_cast<float>(b[k]);
      record[9 + k] = static_cast<float>(c[k]);
    }
    out.write(reinterpret_cast<const char*>(record), sizeof record);
    const uint16_t attribute = 0;
    out.write(reinterpret_cast<const char*>(&attribute), sizeof attribute);
  }
  if (!out) throw input_error(path, "cannot be written");
}

Mesh load_mesh(const std::string& path, double scale) {
  if (!is_file(path)) throw input_error(path, "no such mesh file");
  std::error_code size_error;
  if (std::filesystem::file_size(path, size_error) == 0 || size_error)
    throw input_error(path, "empty mesh file");
  const std::string ext = lower_extension(path);
  if (ext != ".stl" && ext != ".ply" && ext != ".obj")
    throw input_error(path, "unknown mesh format '" + ext + "' (STL, PLY or OBJ)");
  if (ext == ".ply" || ext == ".obj") {  // ours: Assimp asserted on a valid binary PLY, leaked on OBJs
    Mesh mesh;
    if (ext == ".ply")
      mesh.vertices = read_ply_mesh(path, mesh.faces);
    else
      mesh = read_obj(path);
    for (Vec3& v : mesh.vertices) v *= scale;
    check_mesh(path, mesh, scale);
    return mesh;
  }
  return read_with_assimp(path, scale);
}

Mesh load_robot_mesh(const std::string& path, double scale) {
  const std::string ext = lower_extension(path);
  if (ext != ".dae") return load_mesh(path, scale);
  if (!is_file(path)) throw input_error(path, "no such mesh file");
  return read_with_assimp(path, scale, true);
}

}  // namespace weldtwin
