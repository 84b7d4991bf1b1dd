// Rays against one triangle mesh through Embree: what the localizer asks of a part model (is a face seen from
// outside, how thick is the material behind it) at a million rays a second instead of a triangle loop.
#pragma once

#include <memory>

#include "perception/mesh_io.hpp"

namespace weldtwin {

class MeshRays {
 public:
  explicit MeshRays(const Mesh& mesh);
  ~MeshRays();
  MeshRays(const MeshRays&) = delete;
  MeshRays& operator=(const MeshRays&) = delete;

  /// Distance along unit `d` from `o` to the first triangle beyond `t_min`, or +inf if none before `t_max`.
  double hit(const Vec3& o, const Vec3& d, double t_min = 1e-5, double t_max = 1e30) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace weldtwin
