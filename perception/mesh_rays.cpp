#include "perception/mesh_rays.hpp"

#include <embree3/rtcore.h>

#include <limits>
#include <stdexcept>

namespace weldtwin {

struct MeshRays::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

MeshRays::MeshRays(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice("threads=1,verbose=0");
  if (!impl_->device) throw std::runtime_error("Embree: cannot create a device");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.vertices.size()));
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) v[3 * i + static_cast<size_t>(k)] = static_cast<float>(mesh.vertices[i][k]);
  auto* f = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                           3 * sizeof(unsigned), mesh.faces.size()));
  for (size_t i = 0; i < mesh.faces.size(); ++i)
    for (int k = 0; k < 3; ++k) f[3 * i + static_cast<size_t>(k)] = static_cast<unsigned>(mesh.faces[i][k]);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
}

MeshRays::~MeshRays() {
  rtcReleaseScene(impl_->scene);
  rtcReleaseDevice(impl_->device);
}

double MeshRays::hit(const Vec3& o, const Vec3& d, double t_min, double t_max) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(o.x());
  rh.ray.org_y = static_cast<float>(o.y());
  rh.ray.org_z = static_cast<float>(o.z());
  rh.ray.dir_x = static_cast<float>(d.x());
  rh.ray.dir_y = static_cast<float>(d.y());
  rh.ray.dir_z = static_cast<float>(d.z());
  rh.ray.tnear = static_cast<float>(t_min);
  rh.ray.tfar = static_cast<float>(std::min(t_max, 1e30));
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &ctx, &rh);
  return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? std::numeric_limits<double>::infinity()
                                                  : static_cast<double>(rh.ray.tfar);
}

}  // namespace weldtwin
