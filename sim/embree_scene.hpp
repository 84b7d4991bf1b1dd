// The cell for LiDAR ray casting. Geoms fixed to the world go into one Embree scene, built once: boxes and
// meshes as triangles, planes, spheres, capsules, cylinders and ellipsoids as exact user geometry. Geoms of
// moving bodies (the arm) are primitives, tested exactly, and meshes, each in a small Embree scene of its own
// in its body's frame; each View (one per thread) poses them from an mjData and tests them behind a bounding
// sphere per body and per geom, so moving the arm costs no Embree rebuild and threads never wait on each
// other. Every hit distance is computed or refined in double precision on the exact geom, so
// distances match mj_ray.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include <embree3/rtcore.h>
#include <mujoco/mujoco.h>

#include "core/geometry.hpp"

namespace weldtwin {

struct RayHit {
  double distance_m = -1.0;    ///< along the unit direction; < 0: no hit
  int geom = -1;               ///< MuJoCo geom id
  Vec3 normal = Vec3::Zero();  ///< unit surface normal, world frame, facing the ray's origin
  bool hit() const { return distance_m >= 0.0; }
};

class EmbreeScene {
 public:
  /// Builds the scene from the model; static geoms are placed with `d`'s poses (after mj_kinematics).
  /// `include`, if given, picks the geoms (by MuJoCo id) that take part; the rest are left out.
  EmbreeScene(const mjModel* m, const mjData* d, const std::function<bool(int geom)>& include = nullptr);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  struct Shape;  ///< one geom's exact geometry (internal)
  struct MovingBody;

  class View {
   public:
    explicit View(const EmbreeScene& scene);
    /// Poses the moving bodies as in `d` (after mj_kinematics).
    void update(const mjData* d);
    /// Poses the moving bodies: T_world_body[i] for moving_bodies()[i].
    void update(const std::vector<Iso3>& T_world_body);
    /// Promises that the next rays lie in the plane through `origin` with unit normal `normal`, give or take
    /// `slack_m` plus `slack_rad` times the distance from the origin; moving shapes that cannot meet such a
    /// ray are skipped until the next update(). A LiDAR's rays all lie in its scan plane.
    void restrict_to_plane(const Vec3& origin, const Vec3& normal, double slack_m, double slack_rad);
    /// The first hit along origin + t * dir, t in [t_min, t_max]; dir must be unit length.
    RayHit cast(const Vec3& origin, const Vec3& dir, double t_min, double t_max) const;

   private:
    const EmbreeScene& scene_;
    std::vector<Iso3> T_world_body_, T_body_world_;
    std::vector<Vec3> centre_world_;
    std::vector<std::vector<char>> active_;  ///< per moving body and shape: may a ray meet it
    std::vector<char> body_active_;          ///< per moving body: may a ray meet any of its shapes
  };

  View make_view() const { return View(*this); }
  /// MuJoCo ids of the bodies that move (not welded to the world) and carry geoms.
  std::vector<int> moving_bodies() const;
  size_t triangle_count() const { return triangles_; }

 private:
  RTCDevice device_ = nullptr;
  RTCScene static_ = nullptr;
  std::vector<std::unique_ptr<Shape>> static_shapes_;  ///< by Embree geometry id
  std::vector<MovingBody> moving_;
  size_t triangles_ = 0;
};

}  // namespace weldtwin
