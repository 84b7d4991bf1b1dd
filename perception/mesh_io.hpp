// Part meshes made ready for registration: their surface sampled, their faces turned outwards, the
// directions a face can be seen from. Reading them is core/mesh_file.hpp.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "core/mesh_file.hpp"

namespace weldtwin {

struct SurfaceSamples {
  std::vector<Vec3> points;
  std::vector<Vec3> normals;  ///< outward unit normals of the faces the points lie on
};

/// Points spread over the faces at about one per `spacing_m` squared (deterministic), skipping faces whose
/// outward normal points down more steeply than `min_normal_z` (the part's underside, which rests on the
/// table).
SurfaceSamples sample_surface(const Mesh& mesh, double spacing_m, double min_normal_z = -0.7);

class MeshRays;
/// Turns every face of a closed mesh to face outwards (a ray leaving along its normal crosses the surface an
/// even number of times; the majority of three such rays decides). Returns the number of faces turned.
int orient_outward(Mesh& mesh);
/// How many of the test directions from a surface point with outward normal `n` (along the normal, tilted
/// up by 30 and 60 deg, straight up) leave the part without hitting it: 0 for a face no scanner above the
/// table can see (an underside, the depths of a tube), more for a face a sweep sees from more places.
int view_directions(const MeshRays& rays, const Vec3& point, const Vec3& n);

}  // namespace weldtwin
