#include "core/mesh_file.hpp"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <tuple>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/files.hpp"
#include "core/mapped_file.hpp"

namespace weldtwin {

namespace {

constexpr double kMaxPartSize = 5.0;       // no part on a welding table is larger [m]
constexpr double kMinPartSize = 0.002;     // nor smaller (a mesh in metres read as millimetres is 1/1000) [m]
constexpr double kDegenerateArea = 1e-14;  // a face with a smaller cross product has no area [m^2]

}  // namespace

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

namespace {

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

// STL as Assimp reads it with its vertices joined: each face's three corners carry the face's normal from the
// file, and a corner is the same vertex as an earlier one at the very same position whose normal is within
// 1e-5 (so that coplanar faces share their corners, faces meeting at an edge do not); vertices in the order
// they first appear. Ours rather than Assimp's: loading Assimp costs every process 9 ms at start.
class StlJoiner {
 public:
  StlJoiner(Mesh& mesh, double scale, const std::string& path)
      : mesh_(mesh), scale_(scale), base_(mesh.vertices.size()), path_(path) {}
  void face(const std::array<float, 3>& normal, const std::array<std::array<float, 3>, 3>& corners) {
    Eigen::Vector3i f;
    for (int k = 0; k < 3; ++k) f[k] = vertex(corners[static_cast<size_t>(k)], normal);
    mesh_.faces.push_back(f);
  }

 private:
  int vertex(const std::array<float, 3>& at, const std::array<float, 3>& normal) {
    constexpr float kNormalTie2 = 1e-10f;  // squared: Assimp's 1e-5 on normals
    // Refused as read: a NaN would break the ordering of the map the corners are joined by.
    if (!std::isfinite(at[0]) || !std::isfinite(at[1]) || !std::isfinite(at[2]))
      throw input_error(path_, "mesh has a non-finite vertex");
    const auto key = std::tuple(at[0], at[1], at[2]);
    std::vector<size_t>& same = at_[key];
    for (size_t u : same) {
      const std::array<float, 3>& n = normals_[u];
      const float dx = n[0] - normal[0], dy = n[1] - normal[1], dz = n[2] - normal[2];
      if (dx * dx + dy * dy + dz * dz <= kNormalTie2) return static_cast<int>(base_ + u);
    }
    same.push_back(normals_.size());
    normals_.push_back(normal);
    mesh_.vertices.push_back(scale_ * Vec3(at[0], at[1], at[2]));
    return static_cast<int>(mesh_.vertices.size() - 1);
  }
  Mesh& mesh_;
  double scale_;
  size_t base_;
  const std::string& path_;
  std::map<std::tuple<float, float, float>, std::vector<size_t>> at_;
  std::vector<std::array<float, 3>> normals_;
};

constexpr size_t kStlHeader = 80, kStlRecord = 50;  // bytes

Mesh read_stl(const std::string& path, double scale) {
  MappedFile file;
  if (!file.map(path)) throw input_error(path, "cannot open the mesh");
  const char* data = file.data();
  const size_t size = file.size();
  Mesh mesh;
  uint32_t count = 0;
  if (size >= kStlHeader + 4) std::memcpy(&count, data + kStlHeader, 4);
  if (size >= kStlHeader + 4 && size == kStlHeader + 4 + kStlRecord * static_cast<size_t>(count)) {
    StlJoiner join(mesh, scale, path);
    mesh.vertices.reserve(3 * static_cast<size_t>(count));
    for (size_t i = 0; i < count; ++i) {
      float v[12];
      std::memcpy(v, data + kStlHeader + 4 + kStlRecord * i, sizeof v);
      join.face({v[0], v[1], v[2]}, {{{v[3], v[4], v[5]}, {v[6], v[7], v[8]}, {v[9], v[10], v[11]}}});
    }
    return mesh;
  }
  // ASCII: solid ... facet normal nx ny nz / outer loop / vertex x y z (three) / endloop / endfacet ...
  // endsolid; each solid a mesh of its own (its vertices joined within it).
  std::istringstream in{std::string(data, size)};
  std::string word;
  if (!(in >> word) || word != "solid")
    throw input_error(path, "cannot read the mesh: neither a binary STL (" + std::to_string(size) +
                                " bytes for " + std::to_string(count) + " faces) nor an ASCII one ('solid')");
  std::unique_ptr<StlJoiner> join = std::make_unique<StlJoiner>(mesh, scale, path);
  std::getline(in, word);  // the solid's name
  // A word of the file as a message quotes it: at most 40 characters, anything unprintable as '?'.
  auto quoted = [](std::string w) {
    if (w.size() > 40) w = w.substr(0, 40) + "...";
    for (char& ch : w)
      if (!std::isprint(static_cast<unsigned char>(ch))) ch = '?';
    return "'" + w + "'";
  };
  auto number = [&]() {
    if (!(in >> word)) throw input_error(path, "cannot read the mesh: the ASCII STL ends inside a facet");
    const char* from = word.data() + (!word.empty() && word[0] == '+' ? 1 : 0);
    float x = 0.0f;
    const auto r = std::from_chars(from, word.data() + word.size(), x);
    if (r.ec != std::errc() || r.ptr != word.data() + word.size())
      throw input_error(path, "cannot read the mesh: " + quoted(word) + " is not a number");
    return x;
  };
  auto expect = [&](const char* what) {
    if (!(in >> word) || word != what)
      throw input_error(
          path, std::string("cannot read the mesh: '") + what + "' expected, " + quoted(word) + " found");
  };
  while (in >> word) {
    if (word == "endsolid") {
      std::getline(in, word);
      continue;
    }
    if (word == "solid") {
      std::getline(in, word);
      join = std::make_unique<StlJoiner>(mesh, scale, path);
      continue;
    }
    if (word != "facet")
      throw input_error(path, "cannot read the mesh: 'facet' expected, " + quoted(word) + " found");
    expect("normal");
    const std::array<float, 3> n{number(), number(), number()};
    expect("outer");
    expect("loop");
    std::array<std::array<float, 3>, 3> corners;
    for (auto& c : corners) {
      expect("vertex");
      c = {number(), number(), number()};
    }
    expect("endloop");
    expect("endfacet");
    join->face(n, corners);
  }
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
  Mesh mesh = read_stl(path, scale);
  if (mesh.faces.empty()) throw input_error(path, "mesh has no triangles");
  check_mesh(path, mesh, scale);
  return mesh;
}

}  // namespace weldtwin
