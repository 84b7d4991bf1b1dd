// The cell as an Embree scene for LiDAR ray casting. Every MuJoCo geom is in it: boxes and meshes as
// triangles, planes, spheres, capsules, cylinders and ellipsoids as exact user geometry. Geoms fixed to the
// world live in one static scene; each moving body has its own scene, instanced with the body's pose. A View
// (one per thread) holds the instances; update() moves them to an mjData's body poses.
// Every hit distance is recomputed in double precision on the exact geom, so distances match mj_ray.
#pragma once

#include <memory>
#include <vector>

#include <embree3/rtcore.h>
#include <mujoco/mujoco.h>

#include "core/geometry.hpp"

namespace weldtwin {

struct RayHit {
  double distance_m = -1.0;    ///< along the unit direction; < 0: no hit
  int geom = -1;               ///< MuJoCo geom id
  Vec3 normal = Vec3::Zero();  ///< unit outward surface normal, world frame
  bool hit() const { return distance_m >= 0.0; }
};

class EmbreeScene {
 public:
  /// Builds the scene from the model; static geoms are placed with `d`'s poses (after mj_kinematics).
  EmbreeScene(const mjModel* m, const mjData* d);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  struct Shape;  // one geom's exact geometry (internal)
  struct Part;   // one Embree child scene: a body or the static world (internal)

  class View {
   public:
    explicit View(const EmbreeScene& scene);
    ~View();
    View(const View&) = delete;
    View& operator=(const View&) = delete;
    /// Moves the bodies to the poses in `d` (after mj_kinematics) and commits.
    void update(const mjData* d);
    /// The first hit along origin + t * dir, t in [t_min, t_max]; dir must be unit length.
    RayHit cast(const Vec3& origin, const Vec3& dir, double t_min, double t_max) const;

   private:
    friend class EmbreeScene;
    const EmbreeScene& scene_;
    RTCScene top_ = nullptr;
    std::vector<RTCGeometry> instances_;
    std::vector<Iso3> T_world_part_;  ///< pose of each part's frame
    std::vector<Iso3> T_part_world_;  ///< and its inverse
  };

  View make_view() const { return View(*this); }
  size_t triangle_count() const { return triangles_; }

 private:
  RTCDevice device_ = nullptr;
  std::vector<std::unique_ptr<Part>> parts_;
  size_t triangles_ = 0;
};

}  // namespace weldtwin
