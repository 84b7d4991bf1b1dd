// Rays against one triangle mesh through Embree: what the localizer asks of a part model (is a face seen from
// outside, how thick is the material behind it) at a million rays a second instead of a triangle loop, and
// what the replay asks of it (how close is the torch, is it inside) by Embree's point queries.
#pragma once

#include <memory>
#include <vector>

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
  /// Distance from `p` to the nearest point of the surface, or +inf when nothing is within `max_m`.
  double distance(const Vec3& p, double max_m) const;
  /// The surface point nearest `p` within `max_m`: false if there is none; else `point` and the outward
  /// normal of its face (the mesh's winding) are set.
  bool closest(const Vec3& p, double max_m, Vec3& point, Vec3& face_normal) const;
  /// Every face with a point within `radius_m` of `p` (Embree's point query, not pruned), in index order.
  void faces_within(const Vec3& p, double radius_m, std::vector<unsigned>& faces) const;
  /// The point of face `f` nearest `p`, and the face's outward normal (the mesh's winding).
  Vec3 closest_on_face(const Vec3& p, unsigned f) const;
  const Vec3& face_normal(unsigned f) const;
  /// Whether `p` is inside the (closed) mesh: the parity of the surface crossings along three rays, by
  /// majority.
  bool inside(const Vec3& p) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace weldtwin
