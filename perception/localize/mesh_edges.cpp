#include "perception/localize/mesh_edges.hpp"

#include <cmath>

namespace weldtwin {
namespace {

constexpr double kVertexKey = 1e6;     // vertices compared to a micrometre
constexpr double kDegenerate = 1e-14;  // a face with a smaller cross product has no normal

}  // namespace

std::vector<MeshEdge> mesh_edges(const Mesh& mesh) {
  std::map<std::array<long long, 3>, int> ids;
  std::vector<int> id(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& v = mesh.vertices[i];
    const std::array<long long, 3> k{std::llround(v.x() * kVertexKey), std::llround(v.y() * kVertexKey),
                                     std::llround(v.z() * kVertexKey)};
    id[i] = ids.emplace(k, static_cast<int>(ids.size())).first->second;
  }
  std::map<std::pair<int, int>, MeshEdge> edges;
  for (size_t fi = 0; fi < mesh.faces.size(); ++fi) {
    const auto& f = mesh.faces[fi];
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec3 n = (b - a).cross(c - a);
    if (n.norm() < kDegenerate) continue;
    for (int k = 0; k < 3; ++k) {
      const size_t vi = static_cast<size_t>(f[k]), vj = static_cast<size_t>(f[(k + 1) % 3]);
      MeshEdge& e = edges[{std::min(id[vi], id[vj]), std::max(id[vi], id[vj])}];
      e.a = vi;
      e.b = vj;
      e.id_a = id[vi];
      e.id_b = id[vj];
      e.faces.push_back(fi);
      e.normals.push_back(n.normalized());
    }
  }
  std::vector<MeshEdge> out;
  out.reserve(edges.size());
  for (auto& [key, e] : edges) out.push_back(std::move(e));
  return out;
}

}  // namespace weldtwin
