#include "perception/embree_common.hpp"

#include <stdexcept>

namespace weldtwin::embree {

RTCDevice new_device() {
  RTCDevice device = rtcNewDevice("threads=1,verbose=0");
  if (!device) throw std::runtime_error("Embree: cannot create a device");
  return device;
}

RTCGeometry triangle_geometry(RTCDevice device, const std::vector<Vec3>& vertices,
                              const std::vector<Eigen::Vector3i>& triangles) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), vertices.size()));
  for (size_t k = 0; k < vertices.size(); ++k)
    for (int c = 0; c < 3; ++c) v[3 * k + static_cast<size_t>(c)] = static_cast<float>(vertices[k][c]);
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), triangles.size()));
  for (size_t k = 0; k < triangles.size(); ++k)
    for (int c = 0; c < 3; ++c) idx[3 * k + static_cast<size_t>(c)] = static_cast<unsigned>(triangles[k][c]);
  return geom;
}

RTCScene mesh_scene(RTCDevice device, const std::vector<Vec3>& vertices,
                    const std::vector<Eigen::Vector3i>& triangles) {
  RTCScene scene = rtcNewScene(device);
  RTCGeometry geom = triangle_geometry(device, vertices, triangles);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  return scene;
}

RTCRayHit ray(const Vec3& origin, const Vec3& dir, double t_min, double t_max) {
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(origin.x());
  rh.ray.org_y = static_cast<float>(origin.y());
  rh.ray.org_z = static_cast<float>(origin.z());
  rh.ray.dir_x = static_cast<float>(dir.x());
  rh.ray.dir_y = static_cast<float>(dir.y());
  rh.ray.dir_z = static_cast<float>(dir.z());
  rh.ray.tnear = static_cast<float>(t_min);
  rh.ray.tfar = static_cast<float>(t_max);
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

}  // namespace weldtwin::embree
