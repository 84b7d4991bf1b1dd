// What the project's two Embree users share (MeshRays: one part mesh for the localizer and the replay;
// EmbreeScene: the twin's whole cell for the LiDAR): the device, triangles as an Embree geometry, and a ray
// as Embree takes it. Included by those two sources only (Embree's header stays out of the others).
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include "core/geometry.hpp"

namespace weldtwin::embree {

/// A device for one scene (its builds single-threaded: the callers run in parallel above it). Throws
/// std::runtime_error when Embree cannot make one.
RTCDevice new_device();

/// Triangles (indices into `vertices`) as an Embree geometry of `device`, in float (hits that must be exact
/// are refined in double by the caller); not yet committed.
RTCGeometry triangle_geometry(RTCDevice device, const std::vector<Vec3>& vertices,
                              const std::vector<Eigen::Vector3i>& triangles);

/// A committed scene of `device` holding those triangles alone: one mesh to cast rays at and query (a part's
/// mesh; a moving body's mesh in its own frame).
RTCScene mesh_scene(RTCDevice device, const std::vector<Vec3>& vertices,
                    const std::vector<Eigen::Vector3i>& triangles);

/// The ray from `origin` along unit `dir` over [t_min, t_max] as Embree takes it, with no hit yet.
RTCRayHit ray(const Vec3& origin, const Vec3& dir, double t_min, double t_max);

}  // namespace weldtwin::embree
