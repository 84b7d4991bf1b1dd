// Part meshes as files: STL (binary or ascii), PLY and OBJ through our own readers; robot meshes also as
// COLLADA, through Assimp; checked (finite, faces naming vertices, a size a part can have).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

struct Mesh {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> faces;
};

/// Writes `mesh` as binary STL (metres, each face's normal from its winding). Throws InputError naming the
/// file when it cannot be written.
void write_stl(const Mesh& mesh, const std::string& path, const std::string& header = "weldtwin");

/// Loads a mesh, scaled by `scale` (1 for metres, 1e-3 for a mesh in millimetres). Throws InputError naming
/// the file for a missing, empty, malformed or non-finite mesh.
Mesh load_mesh(const std::string& path, double scale = 1.0);

/// A mesh through Assimp (COLLADA with `collada`: its up axis as the file has it), checked as load_mesh
/// checks its own (core/robot_mesh_file.cpp). Throws InputError naming the file.
Mesh read_with_assimp(const std::string& path, double scale, bool collada = false);

/// Refuses a mesh that is non-finite, of a size no part has, or whose faces name missing vertices; drops
/// faces without area. Throws InputError naming `path` (`scale`: as the mesh was read, for the message).
void check_mesh(const std::string& path, Mesh& mesh, double scale);

/// A robot link's mesh as URDFs name them: the formats of load_mesh, and COLLADA (.dae; its up axis as the
/// file has it, as URDF places meshes). Throws InputError naming the file.
Mesh load_robot_mesh(const std::string& path, double scale = 1.0);

}  // namespace weldtwin
