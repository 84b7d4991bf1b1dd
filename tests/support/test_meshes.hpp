// Meshes whose answers are known in closed form, built in code for the perception tests.
#pragma once

#include "perception/mesh_io.hpp"

namespace weldtwin::test {

/// The cube [-h, h]^3: 12 triangles, wound outward.
inline Mesh cube_mesh(double h) {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.faces.emplace_back(q[0], q[1], q[2]);
    m.faces.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

}  // namespace weldtwin::test
