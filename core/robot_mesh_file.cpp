// Robot meshes as URDFs name them: the part formats through load_mesh, COLLADA through Assimp (the one place
// the project loads Assimp: the localize program, which reads no robot, starts without it).
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/mesh_file.hpp"

namespace weldtwin {

// A mesh through Assimp: every node's meshes in the file's frame.
// A COLLADA file's up axis is not turned into Assimp's Y-up: URDFs place their meshes as the file has them.
Mesh read_with_assimp(const std::string& path, double scale, bool collada) {
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

Mesh load_robot_mesh(const std::string& path, double scale) {
  const std::string ext = lower_extension(path);
  if (ext != ".dae") return load_mesh(path, scale);
  if (!is_file(path)) throw input_error(path, "no such mesh file");
  return read_with_assimp(path, scale, true);
}

}  // namespace weldtwin
