// The edges of a triangle mesh, with the faces that meet at each: vertices are merged by position first (a
// mesh file may repeat them per face).
#pragma once

#include <array>
#include <map>
#include <vector>

#include "perception/mesh_io.hpp"

namespace weldtwin {

struct MeshEdge {
  size_t a = 0, b = 0;     ///< the edge's ends (indices into the mesh's vertices), as the last face saw them
  int id_a = 0, id_b = 0;  ///< ... and their merged ids (the ends of every edge at one position share one)
  std::vector<size_t> faces;  ///< faces using the edge (face indices), in the mesh's order
  std::vector<Vec3> normals;  ///< ... and their unit normals
};

/// Every edge of the non-degenerate faces, ordered by the merged ids of its ends.
std::vector<MeshEdge> mesh_edges(const Mesh& mesh);

}  // namespace weldtwin
