#include "sim/embree_scene.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "sim/ray_geom.hpp"

namespace weldtwin {

// One geom in its part's frame: its pose there, its kind, and for triangle geometry the vertices in double.
struct EmbreeScene::Shape {
  int geom = -1;
  int type = mjGEOM_BOX;
  Iso3 T_part_geom = Iso3::Identity();
  Iso3 T_geom_part = Iso3::Identity();
  double size[3] = {0, 0, 0};
  std::vector<Vec3> vertices;              ///< triangles only, in the part frame
  std::vector<Eigen::Vector3i> triangles;  ///< triangles only
};

struct EmbreeScene::Part {
  int body = 0;  ///< MuJoCo body whose frame this part uses; 0 for the static world
  RTCScene scene = nullptr;
  std::vector<Shape> shapes;  ///< by Embree geometry id
};

namespace {

// The intersection context carries the ray in double, so that user geometry is intersected exactly.
struct Context {
  RTCIntersectContext embree;
  const EmbreeScene::View* view;
  Vec3 origin, dir;
  const std::vector<Iso3>* T_part_world;
};

// Exact intersection of a ray given in the shape's part frame.
double intersect_shape(const EmbreeScene::Shape& s, int prim, const Vec3& o_part, const Vec3& d_part, double t_min,
                       Vec3* n_part) {
  if (!s.triangles.empty()) {
    const Eigen::Vector3i& f = s.triangles[static_cast<size_t>(prim)];
    return raygeom::triangle(o_part, d_part, s.vertices[static_cast<size_t>(f[0])],
                             s.vertices[static_cast<size_t>(f[1])], s.vertices[static_cast<size_t>(f[2])], t_min,
                             n_part);
  }
  const Vec3 o = s.T_geom_part * o_part, d = s.T_geom_part.linear() * d_part;
  Vec3 n;
  double t = -1.0;
  switch (s.type) {
    case mjGEOM_PLANE: t = raygeom::plane(o, d, s.size, t_min, &n); break;
    case mjGEOM_SPHERE: t = raygeom::sphere(o, d, s.size[0], t_min, &n); break;
    case mjGEOM_ELLIPSOID: t = raygeom::ellipsoid(o, d, s.size, t_min, &n); break;
    case mjGEOM_CAPSULE: t = raygeom::capsule(o, d, s.size[0], s.size[1], t_min, &n); break;
    case mjGEOM_CYLINDER: t = raygeom::cylinder(o, d, s.size[0], s.size[1], t_min, &n); break;
    case mjGEOM_BOX: t = raygeom::box(o, d, s.size, t_min, &n); break;
    default: return -1.0;
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
      case mjGEOM_SPHERE: half[k] = s->size[0]; break;
      case mjGEOM_CAPSULE: half[k] = axial * s->size[1] + s->size[0]; break;
      case mjGEOM_CYLINDER: half[k] = axial * s->size[1] + radial * s->size[0]; break;
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
  const unsigned inst = args->context->instID[0];
  const Iso3& T_part_world = (*ctx->T_part_world)[inst];
  const Vec3 o = T_part_world * ctx->origin, d = T_part_world.linear() * ctx->dir;
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
    RTCHitN_instID(hits, args->N, i, 0) = inst;
  }
}

void user_occluded(const RTCOccludedFunctionNArguments* args) {
  const auto* s = static_cast<const EmbreeScene::Shape*>(args->geometryUserPtr);
  const auto* ctx = reinterpret_cast<const Context*>(args->context);
  const Iso3& T_part_world = (*ctx->T_part_world)[args->context->instID[0]];
  const Vec3 o = T_part_world * ctx->origin, d = T_part_world.linear() * ctx->dir;
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
      s.vertices.push_back(T * Vec3((k & 1 ? 1 : -1) * s.size[0], (k & 2 ? 1 : -1) * s.size[1],
                                    (k & 4 ? 1 : -1) * s.size[2]));
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
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

}  // namespace

EmbreeScene::EmbreeScene(const mjModel* m, const mjData* d) {
  device_ = rtcNewDevice("threads=1,verbose=0");
  if (!device_) throw std::runtime_error("Embree: cannot create a device");

  // Group geoms: static (welded to the world) into part 0, others by body.
  std::vector<int> part_of_body(static_cast<size_t>(m->nbody), -1);
  parts_.push_back(std::make_unique<Part>());
  part_of_body[0] = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    const int body = m->geom_bodyid[g];
    const bool is_static = m->body_weldid[body] == 0;
    int& p = part_of_body[static_cast<size_t>(is_static ? 0 : body)];
    if (p < 0) {
      p = static_cast<int>(parts_.size());
      parts_.push_back(std::make_unique<Part>());
      parts_.back()->body = body;
    }
    Shape s;
    s.geom = g;
    s.type = m->geom_type[g];
    for (int k = 0; k < 3; ++k) s.size[k] = m->geom_size[3 * g + k];
    // Static geoms in world coordinates; moving ones in their body frame.
    s.T_part_geom = is_static ? pose_of(d->geom_xpos + 3 * g, d->geom_xmat + 9 * g) : geom_in_body(m, g);
    s.T_geom_part = s.T_part_geom.inverse();
    if (s.type == mjGEOM_BOX || s.type == mjGEOM_MESH) triangulate(m, g, s);
    if (s.type == mjGEOM_HFIELD)
      throw std::runtime_error("Embree scene: geom type " + std::to_string(s.type) + " is not supported");
    parts_[static_cast<size_t>(p)]->shapes.push_back(std::move(s));
  }

  for (auto& part : parts_) {
    part->scene = rtcNewScene(device_);
    for (size_t i = 0; i < part->shapes.size(); ++i) {
      Shape& s = part->shapes[i];
      RTCGeometry geom;
      if (!s.triangles.empty()) {
        geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              3 * sizeof(float), s.vertices.size()));
        for (size_t k = 0; k < s.vertices.size(); ++k)
          for (int c = 0; c < 3; ++c) v[3 * k + static_cast<size_t>(c)] = static_cast<float>(s.vertices[k][c]);
        auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(unsigned), s.triangles.size()));
        for (size_t k = 0; k < s.triangles.size(); ++k)
          for (int c = 0; c < 3; ++c) idx[3 * k + static_cast<size_t>(c)] = static_cast<unsigned>(s.triangles[k][c]);
        triangles_ += s.triangles.size();
      } else {
        geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(geom, 1);
        rtcSetGeometryUserData(geom, &s);
        rtcSetGeometryBoundsFunction(geom, user_bounds, nullptr);
        rtcSetGeometryIntersectFunction(geom, user_intersect);
        rtcSetGeometryOccludedFunction(geom, user_occluded);
      }
      rtcCommitGeometry(geom);
      const unsigned id = rtcAttachGeometry(part->scene, geom);
      rtcReleaseGeometry(geom);
      if (id != i) throw std::logic_error("Embree geometry ids are not sequential");
    }
    rtcCommitScene(part->scene);
  }
}

EmbreeScene::~EmbreeScene() {
  for (auto& part : parts_) rtcReleaseScene(part->scene);
  rtcReleaseDevice(device_);
}

EmbreeScene::View::View(const EmbreeScene& scene) : scene_(scene) {
  top_ = rtcNewScene(scene.device_);
  rtcSetSceneFlags(top_, RTC_SCENE_FLAG_DYNAMIC);
  rtcSetSceneBuildQuality(top_, RTC_BUILD_QUALITY_REFIT);
  for (const auto& part : scene.parts_) {
    RTCGeometry inst = rtcNewGeometry(scene.device_, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(inst, part->scene);
    rtcSetGeometryTimeStepCount(inst, 1);
    rtcAttachGeometry(top_, inst);
    instances_.push_back(inst);
    T_world_part_.push_back(Iso3::Identity());
    T_part_world_.push_back(Iso3::Identity());
  }
  for (size_t i = 0; i < instances_.size(); ++i) {
    const float identity[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    rtcSetGeometryTransform(instances_[i], 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, identity);
    rtcCommitGeometry(instances_[i]);
  }
  rtcCommitScene(top_);
}

EmbreeScene::View::~View() {
  for (RTCGeometry g : instances_) rtcReleaseGeometry(g);
  rtcReleaseScene(top_);
}

void EmbreeScene::View::update(const mjData* d) {
  for (size_t i = 1; i < instances_.size(); ++i) {
    const int body = scene_.parts_[i]->body;
    const Iso3 T = pose_of(d->xpos + 3 * body, d->xmat + 9 * body);
    T_world_part_[i] = T;
    T_part_world_[i] = T.inverse();
    float xfm[12];
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) xfm[3 * c + r] = static_cast<float>(T.linear()(r, c));
    for (int r = 0; r < 3; ++r) xfm[9 + r] = static_cast<float>(T.translation()[r]);
    rtcSetGeometryTransform(instances_[i], 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
    rtcCommitGeometry(instances_[i]);
  }
  rtcCommitScene(top_);
}

RayHit EmbreeScene::View::cast(const Vec3& origin, const Vec3& dir, double t_min, double t_max) const {
  Context ctx;
  rtcInitIntersectContext(&ctx.embree);
  ctx.view = this;
  ctx.origin = origin;
  ctx.dir = dir;
  ctx.T_part_world = &T_part_world_;

  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(origin.x());
  rh.ray.org_y = static_cast<float>(origin.y());
  rh.ray.org_z = static_cast<float>(origin.z());
  rh.ray.dir_x = static_cast<float>(dir.x());
  rh.ray.dir_y = static_cast<float>(dir.y());
  rh.ray.dir_z = static_cast<float>(dir.z());
  rh.ray.tnear = static_cast<float>(t_min);
  rh.ray.tfar = static_cast<float>(t_max);
  rh.ray.mask = 0xFFFFFFFF;
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(top_, &ctx.embree, &rh);

  RayHit out;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return out;
  const unsigned inst = rh.hit.instID[0];
  const Part& part = *scene_.parts_[inst];
  const Shape& shape = part.shapes[rh.hit.geomID];
  // Refine in double on the exact geometry; the float hit decides only which primitive was hit.
  const Iso3& T = T_world_part_[inst];
  const Iso3& T_part_world = T_part_world_[inst];
  Vec3 n;
  const Vec3 o_part = T_part_world * origin, d_part = T_part_world.linear() * dir;
  double t = intersect_shape(shape, static_cast<int>(rh.hit.primID), o_part, d_part, 0.0, &n);
  if (t < 0.0) {
    // A float-precision grazing hit the exact test rejects by a hair: keep Embree's distance.
    t = rh.ray.tfar;
    n = Vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
  }
  out.distance_m = t;
  out.geom = shape.geom;
  out.normal = (T.linear() * n).normalized();
  if (out.normal.dot(dir) > 0.0) out.normal = -out.normal;  // facing the sensor (two-sided triangles)
  return out;
}

}  // namespace weldtwin
