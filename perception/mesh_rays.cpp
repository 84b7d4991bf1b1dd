#include "perception/mesh_rays.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "perception/embree_common.hpp"

namespace weldtwin {

namespace {

// The point of triangle (a, b, c) nearest to p: by the region of the triangle's plane p projects into
// (a vertex, an edge, or the face), using barycentric tests on the edge vectors.
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace

struct MeshRays::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> faces;
  std::vector<Vec3> normals;  ///< per face, outward by the winding (zero for a degenerate face)
};

namespace {

struct NearestQuery {
  const MeshRays* rays;
  Vec3 p;
  double best_sq;
  Vec3 point = Vec3::Zero();
  unsigned face = 0;
};

bool nearest_triangle(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<NearestQuery*>(args->userPtr);
  const Vec3 c = q->rays->closest_on_face(q->p, args->primID);
  const double d2 = (c - q->p).squaredNorm();
  if (d2 >= q->best_sq) return false;
  q->best_sq = d2;
  q->point = c;
  q->face = args->primID;
  args->query->radius = static_cast<float>(std::sqrt(d2));
  return true;
}

}  // namespace

MeshRays::MeshRays(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->device = embree::new_device();
  impl_->scene = embree::mesh_scene(impl_->device, mesh.vertices, mesh.faces);
  impl_->vertices = mesh.vertices;
  impl_->faces = mesh.faces;
  impl_->normals.reserve(mesh.faces.size());
  for (const Eigen::Vector3i& fi : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(fi[0])], &b = mesh.vertices[static_cast<size_t>(fi[1])],
               &c = mesh.vertices[static_cast<size_t>(fi[2])];
    impl_->normals.push_back((b - a).cross(c - a).normalized());
  }
}

MeshRays::~MeshRays() {
  rtcReleaseScene(impl_->scene);
  rtcReleaseDevice(impl_->device);
}

double MeshRays::hit(const Vec3& o, const Vec3& d, double t_min, double t_max) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh = embree::ray(o, d, t_min, std::min(t_max, 1e30));
  rtcIntersect1(impl_->scene, &ctx, &rh);
  return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? std::numeric_limits<double>::infinity()
                                                  : static_cast<double>(rh.ray.tfar);
}

double MeshRays::distance(const Vec3& p, double max_m) const {
  Vec3 at, normal;
  return closest(p, max_m, at, normal) ? (at - p).norm() : std::numeric_limits<double>::infinity();
}

bool MeshRays::closest(const Vec3& p, double max_m, Vec3& point, Vec3& face_normal) const {
  RTCPointQuery query{};
  query.x = static_cast<float>(p.x());
  query.y = static_cast<float>(p.y());
  query.z = static_cast<float>(p.z());
  query.radius = static_cast<float>(max_m);
  RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  NearestQuery nearest{this, p, max_m * max_m};
  rtcPointQuery(impl_->scene, &query, &ctx, nearest_triangle, &nearest);
  if (nearest.best_sq >= max_m * max_m) return false;
  point = nearest.point;
  face_normal = impl_->normals[nearest.face];
  return true;
}

namespace {

struct WithinQuery {
  const MeshRays* rays;
  Vec3 p;
  double radius_sq;
  std::vector<unsigned>* faces;
};

bool collect_within(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<WithinQuery*>(args->userPtr);
  if ((q->rays->closest_on_face(q->p, args->primID) - q->p).squaredNorm() <= q->radius_sq)
    q->faces->push_back(args->primID);
  return false;
}

}  // namespace

void MeshRays::faces_within(const Vec3& p, double radius_m, std::vector<unsigned>& faces) const {
  faces.clear();
  RTCPointQuery query{};
  query.x = static_cast<float>(p.x());
  query.y = static_cast<float>(p.y());
  query.z = static_cast<float>(p.z());
  query.radius = std::nextafter(static_cast<float>(radius_m), std::numeric_limits<float>::infinity());
  RTCPointQueryContext ctx;
  rtcInitPointQueryContext(&ctx);
  WithinQuery within{this, p, radius_m * radius_m, &faces};
  rtcPointQuery(impl_->scene, &query, &ctx, collect_within, &within);
  std::sort(faces.begin(), faces.end());
}

Vec3 MeshRays::closest_on_face(const Vec3& p, unsigned f) const {
  const Eigen::Vector3i& fi = impl_->faces[f];
  return closest_on_triangle(p, impl_->vertices[static_cast<size_t>(fi[0])],
                             impl_->vertices[static_cast<size_t>(fi[1])],
                             impl_->vertices[static_cast<size_t>(fi[2])]);
}

const Vec3& MeshRays::face_normal(unsigned f) const {
  return impl_->normals[f];
}

bool MeshRays::inside(const Vec3& p) const {
  // Oblique directions, so that the rays do not run along the axis-aligned edges parts are made of; three of
  // them and the majority, because a ray through an edge or a vertex can slip between two triangles (or meet
  // both) and flip its parity.
  static const Vec3 directions[3] = {Vec3(0.1234, 0.2345, 0.9642).normalized(),
                                     Vec3(-0.8311, 0.3127, -0.4597).normalized(),
                                     Vec3(0.3719, -0.9013, 0.2221).normalized()};
  int votes = 0;
  for (const Vec3& d : directions) {
    int crossings = 0;
    for (double t = 0.0; crossings < 1000; ++crossings) {
      const double next = hit(p, d, t + 1e-7);
      if (!std::isfinite(next)) break;
      t = next;
    }
    votes += crossings % 2;
  }
  return votes >= 2;
}

}  // namespace weldtwin
