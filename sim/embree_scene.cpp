#include "sim/embree_scene.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "perception/embree_common.hpp"
#include "sim/mujoco_world.hpp"
#include "sim/ray_geom.hpp"

namespace weldtwin {

// One geom in its part's frame (the world for static geoms, its body for moving ones): its pose there, its
// kind, and for triangle geometry the vertices in double.
struct EmbreeScene::Shape {
  int geom = -1;
  int type = mjGEOM_BOX;
  Iso3 T_part_geom = Iso3::Identity();
  Iso3 T_geom_part = Iso3::Identity();
  double bound_radius = 0.0;  ///< sphere about the geom origin holding the geom
  double size[3] = {0, 0, 0};
  std::vector<Vec3> vertices;              ///< triangles only, in the part frame
  std::vector<Eigen::Vector3i> triangles;  ///< triangles only
  RTCScene local = nullptr;                ///< a moving mesh's own triangles, body frame
};

struct EmbreeScene::MovingBody {
  int body = 0;
  std::vector<Shape> shapes;
  Vec3 centre = Vec3::Zero();  ///< bounding sphere of all shapes, body frame
  double radius = 0.0;
};

namespace {

// The intersection context carries the ray in double, so that user geometry is intersected exactly.
struct Context {
  RTCIntersectContext embree;
  Vec3 origin, dir;
};

// Exact intersection of a ray given in the shape's part frame.
double intersect_shape(const EmbreeScene::Shape& s, int prim, const Vec3& o_part, const Vec3& d_part,
                       double t_min, Vec3* n_part) {
  if (!s.triangles.empty()) {
    const Eigen::Vector3i& f = s.triangles[static_cast<size_t>(prim)];
    return raygeom::triangle(o_part, d_part, s.vertices[static_cast<size_t>(f[0])],
                             s.vertices[static_cast<size_t>(f[1])], s.vertices[static_cast<size_t>(f[2])],
                             t_min, n_part);
  }
  const Vec3 o = s.T_geom_part * o_part, d = s.T_geom_part.linear() * d_part;
  Vec3 n;
  double t = -1.0;
  switch (s.type) {
    case mjGEOM_PLANE:
      t = raygeom::plane(o, d, s.size, t_min, &n);
      break;
    case mjGEOM_SPHERE:
      t = raygeom::sphere(o, d, s.size[0], t_min, &n);
      break;
    case mjGEOM_ELLIPSOID:
      t = raygeom::ellipsoid(o, d, s.size, t_min, &n);
      break;
    case mjGEOM_CAPSULE:
      t = raygeom::capsule(o, d, s.size[0], s.size[1], t_min, &n);
      break;
    case mjGEOM_CYLINDER:
      t = raygeom::cylinder(o, d, s.size[0], s.size[1], t_min, &n);
      break;
    case mjGEOM_BOX:
      t = raygeom::box(o, d, s.size, t_min, &n);
      break;
    default:
      return -1.0;
  }
  if (t >= 0.0 && n_part) *n_part = s.T_part_geom.linear() * n;
  return t;
}

void user_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* s = static_cast<const EmbreeScene::Shape*>(args->geometryUserPtr);
  // Tight axis-aligned bounds of the posed primitive, padded for float rounding.
  const Mat3& R = s->T_part_geom.linear();
  Vec3 half = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    const Vec3 row = R.row(k);  // the part axis k in geom coordinates
    const double axial = std::abs(row.z()), radial = std::sqrt(std::max(0.0, 1.0 - row.z() * row.z()));
    switch (s->type) {
      case mjGEOM_PLANE: {
        const double sx = s->size[0] > 0 ? s->size[0] : 1e3, sy = s->size[1] > 0 ? s->size[1] : 1e3;
        half[k] = std::abs(row.x()) * sx + std::abs(row.y()) * sy;
        break;
      }
      case mjGEOM_SPHERE:
        half[k] = s->size[0];
        break;
      case mjGEOM_CAPSULE:
        half[k] = axial * s->size[1] + s->size[0];
        break;
      case mjGEOM_CYLINDER:
        half[k] = axial * s->size[1] + radial * s->size[0];
        break;
      default:  // ellipsoid, box
        half[k] = Vec3(row.x() * s->size[0], row.y() * s->size[1], row.z() * s->size[2]).norm();
        break;
    }
  }
  half = half * (1.0 + 1e-6) + Vec3::Constant(1e-5);
  const Vec3 lo = s->T_part_geom.translation() - half, hi = s->T_part_geom.translation() + half;
  RTCBounds* b = args->bounds_o;
  b->lower_x = std::nextafter(static_cast<float>(lo.x()), -INFINITY);
  b->lower_y = std::nextafter(static_cast<float>(lo.y()), -INFINITY);
  b->lower_z = std::nextafter(static_cast<float>(lo.z()), -INFINITY);
  b->upper_x = std::nextafter(static_cast<float>(hi.x()), INFINITY);
  b->upper_y = std::nextafter(static_cast<float>(hi.y()), INFINITY);
  b->upper_z = std::nextafter(static_cast<float>(hi.z()), INFINITY);
}

void user_intersect(const RTCIntersectFunctionNArguments* args) {
  const auto* s = static_cast<const EmbreeScene::Shape*>(args->geometryUserPtr);
  const auto* ctx = reinterpret_cast<const Context*>(args->context);
  RTCRayN* rays = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* hits = RTCRayHitN_HitN(args->rayhit, args->N);
  const Vec3& o = ctx->origin;
  const Vec3& d = ctx->dir;
  for (unsigned i = 0; i < args->N; ++i) {
    if (!args->valid[i]) continue;
    const double t_min = RTCRayN_tnear(rays, args->N, i);
    Vec3 n;
    const double t = intersect_shape(*s, 0, o, d, t_min, &n);
    if (t < 0.0 || t >= RTCRayN_tfar(rays, args->N, i)) continue;
    RTCRayN_tfar(rays, args->N, i) = static_cast<float>(t);
    RTCHitN_Ng_x(hits, args->N, i) = static_cast<float>(n.x());
    RTCHitN_Ng_y(hits, args->N, i) = static_cast<float>(n.y());
    RTCHitN_Ng_z(hits, args->N, i) = static_cast<float>(n.z());
    RTCHitN_u(hits, args->N, i) = 0.0f;
    RTCHitN_v(hits, args->N, i) = 0.0f;
    RTCHitN_primID(hits, args->N, i) = args->primID;
    RTCHitN_geomID(hits, args->N, i) = args->geomID;
    RTCHitN_instID(hits, args->N, i, 0) = args->context->instID[0];
  }
}

void user_occluded(const RTCOccludedFunctionNArguments* args) {
  const auto* s = static_cast<const EmbreeScene::Shape*>(args->geometryUserPtr);
  const auto* ctx = reinterpret_cast<const Context*>(args->context);
  const Vec3& o = ctx->origin;
  const Vec3& d = ctx->dir;
  for (unsigned i = 0; i < args->N; ++i) {
    if (!args->valid[i]) continue;
    const double t = intersect_shape(*s, 0, o, d, RTCRayN_tnear(args->ray, args->N, i), nullptr);
    if (t >= 0.0 && t < RTCRayN_tfar(args->ray, args->N, i)) RTCRayN_tfar(args->ray, args->N, i) = -INFINITY;
  }
}

Iso3 pose_of(const mjtNum* pos, const mjtNum* mat) {
  Mat3 R;
  R << mat[0], mat[1], mat[2], mat[3], mat[4], mat[5], mat[6], mat[7], mat[8];
  return make_transform(Vec3(pos[0], pos[1], pos[2]), R);
}

Iso3 geom_in_body(const mjModel* m, int g) {
  const mjtNum* q = m->geom_quat + 4 * g;
  return make_transform(Vec3(m->geom_pos[3 * g], m->geom_pos[3 * g + 1], m->geom_pos[3 * g + 2]),
                        Quat(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix());
}

// Box or mesh geom as triangles in the part frame.
void triangulate(const mjModel* m, int g, EmbreeScene::Shape& s) {
  const Iso3& T = s.T_part_geom;
  if (s.type == mjGEOM_BOX) {
    for (int k = 0; k < 8; ++k)
      s.vertices.push_back(
          T * Vec3((k & 1 ? 1 : -1) * s.size[0], (k & 2 ? 1 : -1) * s.size[1], (k & 4 ? 1 : -1) * s.size[2]));
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
      s.triangles.emplace_back(q[0], q[1], q[2]);
      s.triangles.emplace_back(q[0], q[2], q[3]);
    }
    return;
  }
  const int mesh = m->geom_dataid[g];
  const int v0 = m->mesh_vertadr[mesh], nv = m->mesh_vertnum[mesh];
  const int f0 = m->mesh_faceadr[mesh], nf = m->mesh_facenum[mesh];
  for (int v = 0; v < nv; ++v) {
    const float* p = m->mesh_vert + 3 * (v0 + v);
    s.vertices.push_back(T * Vec3(p[0], p[1], p[2]));
  }
  for (int f = 0; f < nf; ++f) {
    const int* t = m->mesh_face + 3 * (f0 + f);
    s.triangles.emplace_back(t[0], t[1], t[2]);
  }
}

// Radius of a sphere about the geom's origin that holds it.
double bounding_radius(const EmbreeScene::Shape& s) {
  if (!s.vertices.empty()) {
    double r = 0.0;
    for (const Vec3& v : s.vertices) r = std::max(r, (v - s.T_part_geom.translation()).norm());
    return r;
  }
  switch (s.type) {
    case mjGEOM_PLANE:
      return 1e3;
    case mjGEOM_SPHERE:
      return s.size[0];
    case mjGEOM_CAPSULE:
      return s.size[0] + s.size[1];
    case mjGEOM_CYLINDER:
      return std::hypot(s.size[0], s.size[1]);
    default:
      return Vec3(s.size[0], s.size[1], s.size[2]).norm();
  }
}

// One ray through an Embree scene; the context carries it in double for user geometry.
RTCRayHit embree_cast(RTCScene scene, const Vec3& origin, const Vec3& dir, double t_min, double t_max) {
  Context ctx;
  rtcInitIntersectContext(&ctx.embree);
  ctx.origin = origin;
  ctx.dir = dir;
  RTCRayHit rh = embree::ray(origin, dir, t_min, t_max);
  rtcIntersect1(scene, &ctx.embree, &rh);
  return rh;
}

// Embree's float hit on a shape refined in double on the exact geometry; the float hit decides only which
// primitive was hit. A grazing hit the exact test rejects by a hair keeps Embree's distance.
double refine_hit(const EmbreeScene::Shape& s, const RTCRayHit& rh, const Vec3& o, const Vec3& d,
                  double t_min, Vec3* n) {
  const double t = intersect_shape(s, static_cast<int>(rh.hit.primID), o, d, t_min, n);
  if (t >= 0.0) return t;
  *n = Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
  return rh.ray.tfar;
}

}  // namespace

EmbreeScene::EmbreeScene(const mjModel* m, const mjData* d, const std::function<bool(int geom)>& include) {
  device_ = embree::new_device();
  static_ = rtcNewScene(device_);

  std::vector<int> moving_of_body(static_cast<size_t>(m->nbody), -1);
  for (int g = 0; g < m->ngeom; ++g) {
    if ((include && !include(g)) || !seen(m, g)) continue;
    if (m->geom_type[g] == mjGEOM_HFIELD)
      throw std::runtime_error("Embree scene: height fields are not supported");
    const int body = m->geom_bodyid[g];
    const bool is_static = m->body_weldid[body] == 0;
    auto s = std::make_unique<Shape>();
    s->geom = g;
    s->type = m->geom_type[g];
    for (int k = 0; k < 3; ++k) s->size[k] = m->geom_size[3 * g + k];
    // Static geoms in world coordinates; moving ones in their body frame.
    s->T_part_geom = is_static ? pose_of(d->geom_xpos + 3 * g, d->geom_xmat + 9 * g) : geom_in_body(m, g);
    s->T_geom_part = s->T_part_geom.inverse();
    if (s->type == mjGEOM_MESH || (is_static && s->type == mjGEOM_BOX)) triangulate(m, g, *s);
    if (!is_static) {
      if (!s->triangles.empty()) {
        s->local = embree::mesh_scene(device_, s->vertices, s->triangles);
      }
      int& k = moving_of_body[static_cast<size_t>(body)];
      if (k < 0) {
        k = static_cast<int>(moving_.size());
        moving_.emplace_back();
        moving_.back().body = body;
      }
      moving_[static_cast<size_t>(k)].shapes.push_back(std::move(*s));
      continue;
    }
    RTCGeometry geom;
    if (!s->triangles.empty()) {
      geom = embree::triangle_geometry(device_, s->vertices, s->triangles);
      triangles_ += s->triangles.size();
    } else {
      geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(geom, 1);
      rtcSetGeometryUserData(geom, s.get());
      rtcSetGeometryBoundsFunction(geom, user_bounds, nullptr);
      rtcSetGeometryIntersectFunction(geom, user_intersect);
      rtcSetGeometryOccludedFunction(geom, user_occluded);
    }
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(static_, geom);
    rtcReleaseGeometry(geom);
    if (id != static_shapes_.size()) throw std::logic_error("Embree geometry ids are not sequential");
    static_shapes_.push_back(std::move(s));
  }
  rtcCommitScene(static_);

  // A bounding sphere per moving body: the centroid of its shapes' centres, and the farthest shape extent.
  for (MovingBody& b : moving_) {
    for (Shape& s : b.shapes) s.bound_radius = bounding_radius(s) * (1.0 + 1e-9) + 1e-9;
    b.centre = Vec3::Zero();
    for (const Shape& s : b.shapes) b.centre += s.T_part_geom.translation();
    b.centre /= static_cast<double>(b.shapes.size());
    for (const Shape& s : b.shapes)
      b.radius = std::max(b.radius, (s.T_part_geom.translation() - b.centre).norm() + bounding_radius(s));
    b.radius = b.radius * (1.0 + 1e-9) + 1e-9;
  }
}

EmbreeScene::~EmbreeScene() {
  for (MovingBody& b : moving_)
    for (Shape& s : b.shapes)
      if (s.local) rtcReleaseScene(s.local);
  rtcReleaseScene(static_);
  rtcReleaseDevice(device_);
}

EmbreeScene::View::View(const EmbreeScene& scene)
    : scene_(scene),
      T_world_body_(scene.moving_.size(), Iso3::Identity()),
      T_body_world_(scene.moving_.size(), Iso3::Identity()),
      centre_world_(scene.moving_.size(), Vec3::Zero()),
      active_(scene.moving_.size()),
      body_active_(scene.moving_.size(), 1) {
  for (size_t i = 0; i < scene.moving_.size(); ++i) active_[i].assign(scene.moving_[i].shapes.size(), 1);
}

std::vector<int> EmbreeScene::moving_bodies() const {
  std::vector<int> out;
  for (const MovingBody& b : moving_) out.push_back(b.body);
  return out;
}

void EmbreeScene::View::update(const mjData* d) {
  std::vector<Iso3> poses;
  for (const MovingBody& b : scene_.moving_)
    poses.push_back(pose_of(d->xpos + 3 * b.body, d->xmat + 9 * b.body));
  update(poses);
}

void EmbreeScene::View::update(const std::vector<Iso3>& T_world_body) {
  for (size_t i = 0; i < scene_.moving_.size(); ++i) {
    T_world_body_[i] = T_world_body[i];
    T_body_world_[i] = T_world_body[i].inverse();
    centre_world_[i] = T_world_body[i] * scene_.moving_[i].centre;
    active_[i].assign(scene_.moving_[i].shapes.size(), 1);
    body_active_[i] = 1;
  }
}

void EmbreeScene::View::restrict_to_plane(const Vec3& origin, const Vec3& normal, double slack_m,
                                          double slack_rad) {
  for (size_t i = 0; i < scene_.moving_.size(); ++i) {
    const MovingBody& b = scene_.moving_[i];
    const Vec3 n = T_body_world_[i].linear() * normal;  // the plane normal in the body frame
    const Vec3 o = T_body_world_[i] * origin;
    for (size_t k = 0; k < b.shapes.size(); ++k) {
      const Shape& s = b.shapes[k];
      // Half-extent of the posed primitive along the normal (the support function), exact for each type.
      const Vec3 ng = s.T_geom_part.linear() * n;
      double extent = s.bound_radius;
      switch (s.type) {
        case mjGEOM_BOX:
          extent = std::abs(ng.x()) * s.size[0] + std::abs(ng.y()) * s.size[1] + std::abs(ng.z()) * s.size[2];
          break;
        case mjGEOM_CYLINDER:
          extent = std::abs(ng.z()) * s.size[1] + std::sqrt(std::max(0.0, 1.0 - ng.z() * ng.z())) * s.size[0];
          break;
        case mjGEOM_CAPSULE:
          extent = std::abs(ng.z()) * s.size[1] + s.size[0];
          break;
        case mjGEOM_SPHERE:
          extent = s.size[0];
          break;
        default:
          break;
      }
      const Vec3 c = s.T_part_geom.translation() - o;
      const double reach = c.norm() + s.bound_radius;
      active_[i][k] = std::abs(c.dot(n)) <= extent + slack_m + slack_rad * reach + 1e-9;
    }
    body_active_[i] = std::find(active_[i].begin(), active_[i].end(), 1) != active_[i].end();
  }
}

RayHit EmbreeScene::View::cast(const Vec3& origin, const Vec3& dir, double t_min, double t_max) const {
  RayHit out;
  // The static world through Embree.
  const RTCRayHit rh = embree_cast(scene_.static_, origin, dir, t_min, t_max);
  double best = t_max;
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    const Shape& shape = *scene_.static_shapes_[rh.hit.geomID];
    Vec3 n;
    out.distance_m = best = refine_hit(shape, rh, origin, dir, t_min, &n);
    out.geom = shape.geom;
    out.normal = n;
  }
  // The moving bodies, exactly, behind their bounding spheres.
  for (size_t i = 0; i < scene_.moving_.size(); ++i) {
    if (!body_active_[i]) continue;
    const MovingBody& b = scene_.moving_[i];
    const Vec3 oc = centre_world_[i] - origin;
    const double tca = oc.dot(dir), d2 = oc.squaredNorm() - tca * tca, r2 = b.radius * b.radius;
    if (d2 > r2) continue;
    const double half = std::sqrt(r2 - d2);
    if (tca + half < t_min || tca - half > best) continue;
    const Vec3 o = T_body_world_[i] * origin, d = T_body_world_[i].linear() * dir;
    for (size_t k = 0; k < b.shapes.size(); ++k) {
      if (!active_[i][k]) continue;
      const Shape& s = b.shapes[k];
      // Each shape behind its own bounding sphere too.
      const Vec3 sc = s.T_part_geom.translation() - o;
      const double sca = sc.dot(d), sd2 = sc.squaredNorm() - sca * sca, sr2 = s.bound_radius * s.bound_radius;
      if (sd2 > sr2 || sca + s.bound_radius < t_min || sca - s.bound_radius > best) continue;
      Vec3 n;
      double t = -1.0;
      if (s.triangles.empty()) {
        t = intersect_shape(s, 0, o, d, t_min, &n);
      } else {
        const RTCRayHit lh = embree_cast(s.local, o, d, t_min, best);
        if (lh.hit.geomID != RTC_INVALID_GEOMETRY_ID) t = refine_hit(s, lh, o, d, t_min, &n);
      }
      if (t >= 0.0 && t < best) {
        out.distance_m = best = t;
        out.geom = s.geom;
        out.normal = T_world_body_[i].linear() * n;
      }
    }
  }
  if (out.hit()) {
    out.normal.normalize();
    if (out.normal.dot(dir) > 0.0) out.normal = -out.normal;  // facing the sensor (two-sided triangles)
  }
  return out;
}

}  // namespace weldtwin
