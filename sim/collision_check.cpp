#include "sim/collision_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "perception/mesh_rays.hpp"
#include "sim/contact_screen.hpp"

namespace weldtwin {
namespace {

// Points on the surface of a primitive geom, in the geom's frame, about `spacing` apart.
std::vector<Vec3> geom_surface_points(int type, const double* size, double spacing) {
  std::vector<Vec3> pts;
  auto steps = [&](double len) { return std::max(1, static_cast<int>(std::ceil(len / spacing))); };
  if (type == mjGEOM_CYLINDER || type == mjGEOM_CAPSULE) {
    const double r = size[0], hz = size[1];
    const int na = std::max(8, steps(2 * kPi * r)), nz = steps(2 * hz);
    for (int i = 0; i <= nz; ++i)
      for (int a = 0; a < na; ++a) {
        const double th = 2 * kPi * a / na;
        pts.emplace_back(r * std::cos(th), r * std::sin(th), -hz + 2 * hz * i / nz);
      }
    for (double z : {-hz, hz})
      for (int ir = 1, nr = steps(r); ir < nr; ++ir) {
        const double rr = r * ir / nr;
        const int n = std::max(6, steps(2 * kPi * rr));
        for (int a = 0; a < n; ++a)
          pts.emplace_back(rr * std::cos(2 * kPi * a / n), rr * std::sin(2 * kPi * a / n), z);
      }
    if (type == mjGEOM_CAPSULE)
      for (double z : {-hz - r, hz + r}) pts.emplace_back(0, 0, z);
  } else if (type == mjGEOM_BOX) {
    for (int axis = 0; axis < 3; ++axis) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const int nu = steps(2 * size[u]), nv = steps(2 * size[v]);
      for (double side : {-1.0, 1.0})
        for (int i = 0; i <= nu; ++i)
          for (int j = 0; j <= nv; ++j) {
            Vec3 p;
            p[axis] = side * size[axis];
            p[u] = -size[u] + 2 * size[u] * i / nu;
            p[v] = -size[v] + 2 * size[v] * j / nv;
            pts.push_back(p);
          }
    }
  } else if (type == mjGEOM_SPHERE) {
    const int n = std::max(12, static_cast<int>(4 * kPi * size[0] * size[0] / (spacing * spacing)));
    for (int i = 0; i < n; ++i) {  // Fibonacci sphere
      const double z = 1 - 2 * (i + 0.5) / n, rho = std::sqrt(1 - z * z), th = kPi * (3 - std::sqrt(5.0)) * i;
      pts.emplace_back(size[0] * rho * std::cos(th), size[0] * rho * std::sin(th), size[0] * z);
    }
  }
  return pts;
}

// Points on the surface of a mesh geom (its triangles, each sampled on a grid about `spacing` apart), in the
// geom's frame: MuJoCo stores a mesh's vertices in the frame of the geoms that use it.
std::vector<Vec3> mesh_surface_points(const mjModel* m, int mesh, double spacing) {
  std::vector<Vec3> pts;
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
  const int* face = m->mesh_face + 3 * m->mesh_faceadr[mesh];
  auto vertex = [&](int i) { return Vec3(vert[3 * i], vert[3 * i + 1], vert[3 * i + 2]); };
  for (int f = 0; f < m->mesh_facenum[mesh]; ++f) {
    const Vec3 a = vertex(face[3 * f]), b = vertex(face[3 * f + 1]), c = vertex(face[3 * f + 2]);
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing)));
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j)
        pts.push_back(a + (b - a) * (static_cast<double>(i) / n) + (c - a) * (static_cast<double>(j) / n));
  }
  return pts;
}

// A robot geom cut into chunks that are tested as a whole first (one point query for the chunk's centre).
struct Chunk {
  int geom = 0;
  Vec3 center = Vec3::Zero();  ///< geom frame
  double radius = 0.0;
  std::vector<Vec3> points;    ///< geom frame
  std::vector<double> offset;  ///< each point's distance from the centre
};

std::vector<Chunk> make_chunks(const mjModel* m, int geom, double spacing, double chunk_m) {
  const std::vector<Vec3> pts =
      m->geom_type[geom] == mjGEOM_MESH
          ? mesh_surface_points(m, m->geom_dataid[geom], spacing)
          : geom_surface_points(m->geom_type[geom], m->geom_size + 3 * geom, spacing);
  std::map<std::array<int, 3>, Chunk> cells;
  for (const Vec3& p : pts) {
    const std::array<int, 3> key{static_cast<int>(std::floor(p.x() / chunk_m)),
                                 static_cast<int>(std::floor(p.y() / chunk_m)),
                                 static_cast<int>(std::floor(p.z() / chunk_m))};
    cells[key].points.push_back(p);
  }
  std::vector<Chunk> chunks;
  for (auto& [key, c] : cells) {
    c.geom = geom;
    for (const Vec3& p : c.points) c.center += p;
    c.center /= static_cast<double>(c.points.size());
    for (const Vec3& p : c.points) c.offset.push_back((p - c.center).norm());
    c.radius = *std::max_element(c.offset.begin(), c.offset.end());
    chunks.push_back(std::move(c));
  }
  return chunks;
}

// The arm's surface as PartClearance tests it: each measured robot geom's chunks, in its geom frame. It
// depends on the arm's geoms alone, which every layout of a cell (and every cell with the same robot) shares,
// while sampling the vendor's meshes every 3 mm takes about as long as a plan: it is made once per distinct
// arm and shared.
struct RobotSurface {
  struct GeomChunks {
    int geom = 0;
    double radius = 0.0;  ///< a sphere about the geom's origin holding all its chunks
    size_t first = 0, end = 0;
  };
  std::vector<Chunk> chunks;
  std::vector<GeomChunks> geoms;
};

// What the surface is made from, byte for byte: the measured robot geoms' ids, types and sizes, and their
// meshes' vertices and faces.
std::string robot_surface_key(const MujocoWorld& world) {
  const mjModel* m = world.model();
  std::string key;
  const auto add = [&key](const void* p, size_t bytes) { key.append(static_cast<const char*>(p), bytes); };
  for (int g = 0; g < m->ngeom; ++g) {
    if (world.geom_label(g) != Label::kRobot || !measured_for_clearance(m, g)) continue;
    add(&g, sizeof g);
    add(m->geom_type + g, sizeof(int));
    add(m->geom_size + 3 * g, 3 * sizeof(mjtNum));
    if (m->geom_type[g] == mjGEOM_MESH) {
      const int mesh = m->geom_dataid[g];
      add(m->mesh_vert + 3 * m->mesh_vertadr[mesh],
          3 * sizeof(float) * static_cast<size_t>(m->mesh_vertnum[mesh]));
      add(m->mesh_face + 3 * m->mesh_faceadr[mesh],
          3 * sizeof(int) * static_cast<size_t>(m->mesh_facenum[mesh]));
    }
  }
  return key;
}

std::shared_ptr<const RobotSurface> make_robot_surface(const MujocoWorld& world) {
  auto surface = std::make_shared<RobotSurface>();
  const mjModel* m = world.model();
  for (int g = 0; g < m->ngeom; ++g)
    if (world.geom_label(g) == Label::kRobot && measured_for_clearance(m, g)) {
      std::vector<Chunk> c = make_chunks(m, g, 0.003, 0.03);
      RobotSurface::GeomChunks gc;
      gc.geom = g;
      gc.first = surface->chunks.size();
      gc.end = gc.first + c.size();
      for (const Chunk& k : c) gc.radius = std::max(gc.radius, k.center.norm() + k.radius);
      surface->geoms.push_back(gc);
      surface->chunks.insert(surface->chunks.end(), std::make_move_iterator(c.begin()),
                             std::make_move_iterator(c.end()));
    }
  return surface;
}

// The surface of this world's arm: made the first time, then the same one for every world whose measured arm
// geoms are the same to the byte (the last few arms are kept).
std::shared_ptr<const RobotSurface> robot_surface(const MujocoWorld& world) {
  static std::mutex mutex;
  static std::vector<std::pair<std::string, std::shared_ptr<const RobotSurface>>> made;
  constexpr size_t kArmsKept = 4;
  std::string key = robot_surface_key(world);
  std::lock_guard<std::mutex> lock(mutex);
  for (const auto& [k, surface] : made)
    if (k == key) return surface;
  if (made.size() >= kArmsKept) made.erase(made.begin());
  made.emplace_back(std::move(key), make_robot_surface(world));
  return made.back().second;
}

Vec3 geom_to_base(const mjData* d, int g, const Vec3& p) {
  const double* x = d->geom_xpos + 3 * g;
  const double* R = d->geom_xmat + 9 * g;
  return Vec3(x[0] + R[0] * p.x() + R[1] * p.y() + R[2] * p.z(),
              x[1] + R[3] * p.x() + R[4] * p.y() + R[5] * p.z(),
              x[2] + R[6] * p.x() + R[7] * p.y() + R[8] * p.z());
}

std::string geom_name(const mjModel* m, int g) {
  const char* n = mj_id2name(m, mjOBJ_GEOM, g);
  return n ? n : "geom" + std::to_string(g);
}

}  // namespace

struct PartClearance::Impl {
  const MujocoWorld* world = nullptr;
  std::unique_ptr<MeshRays> rays;
  // The arm's chunks, and per geom a sphere about its frame's origin holding them all: a geom whose sphere
  // is farther from the part than the nearest point found so far is passed over with one query.
  std::shared_ptr<const RobotSurface> surface;
  double range = 0.05;
  Iso3 T_base_mesh_part = Iso3::Identity();  ///< where the part stood when the mesh was put in the base frame
  std::optional<Iso3> T_mesh_base;           ///< set when the part was moved since (set_part_pose)
  // The part's box, base frame: a sphere farther from it than the nearest point found is passed over.
  Eigen::AlignedBox3d box;
};

PartClearance::PartClearance(const MujocoWorld& world, const Mesh& part_mesh, const Iso3& T_base_part,
                             double range_m)
    : impl_(std::make_shared<Impl>()) {
  Mesh mesh_base = part_mesh;
  for (Vec3& v : mesh_base.vertices) v = T_base_part * v;
  impl_->world = &world;
  impl_->rays = std::make_unique<MeshRays>(mesh_base);
  for (const Vec3& v : mesh_base.vertices) impl_->box.extend(v);
  impl_->range = range_m;
  impl_->T_base_mesh_part = T_base_part;
  impl_->surface = robot_surface(world);
}

size_t PartClearance::surface_points() const {
  size_t n = 0;
  for (const Chunk& c : impl_->surface->chunks) n += c.points.size();
  return n;
}

void PartClearance::set_part_pose(const Iso3& T_base_part) {
  impl_->T_mesh_base = impl_->T_base_mesh_part * T_base_part.inverse();
}

double PartClearance::clearance(const mjData* d, std::string* geom, Hint* hint) const {
  const MeshRays& rays = *impl_->rays;
  // A robot geom's point in the frame the mesh was built in (the base frame, unless the part was moved).
  const std::optional<Iso3>& T_mesh_base = impl_->T_mesh_base;
  const auto geom_to_base = [&](const mjData* data, int g, const Vec3& p) {
    const Vec3 b = weldtwin::geom_to_base(data, g, p);
    return T_mesh_base ? Vec3(*T_mesh_base * b) : b;
  };
  double best = impl_->range;
  int best_geom = -1;
  Vec3 best_point = Vec3::Zero();
  size_t best_chunk = 0, best_index = 0;
  auto consider = [&](size_t chunk, size_t i, const Vec3& pb) {
    const double dp = rays.distance(pb, best);
    if (dp < best) {
      best = dp;
      best_geom = impl_->surface->chunks[chunk].geom;
      best_point = pb;
      best_chunk = chunk, best_index = i;
    }
  };
  // The nearest point of the last state first: the search then starts with a tight bound.
  if (hint && hint->chunk >= 0 && static_cast<size_t>(hint->chunk) < impl_->surface->chunks.size()) {
    const Chunk& c = impl_->surface->chunks[static_cast<size_t>(hint->chunk)];
    if (static_cast<size_t>(hint->point) < c.points.size())
      consider(static_cast<size_t>(hint->chunk), static_cast<size_t>(hint->point),
               geom_to_base(d, c.geom, c.points[static_cast<size_t>(hint->point)]));
  }
  for (const RobotSurface::GeomChunks& g : impl_->surface->geoms) {
    const Vec3 origin = geom_to_base(d, g.geom, Vec3::Zero());
    if (impl_->box.exteriorDistance(origin) - g.radius >= best) continue;
    const double dg = rays.distance(origin, best + g.radius);
    if (!std::isfinite(dg) || dg - g.radius >= best) continue;
    for (size_t k = g.first; k < g.end; ++k) {
      const Chunk& c = impl_->surface->chunks[k];
      const Vec3 center = geom_to_base(d, c.geom, c.center);
      if (impl_->box.exteriorDistance(center) - c.radius >= best) continue;
      const double dc = rays.distance(center, best + c.radius);
      if (!std::isfinite(dc) || dc - c.radius >= best) continue;
      for (size_t i = 0; i < c.points.size(); ++i)
        if (dc - c.offset[i] < best) consider(k, i, geom_to_base(d, c.geom, c.points[i]));  // else too far
    }
  }
  if (hint)
    *hint = best_geom >= 0 ? Hint{static_cast<int>(best_chunk), static_cast<int>(best_index)} : Hint{};
  if (best_geom >= 0 && best < kInsideTestWithin_m && rays.inside(best_point)) best = -best;
  if (geom) *geom = best_geom >= 0 ? geom_name(impl_->world->model(), best_geom) : "";
  return best;
}

struct CollisionChecker::State {
  const MujocoWorld* world = nullptr;
  std::optional<PartClearance> part;
  double part_margin = 0.0, weld_margin = 0.0;
  ModelPtr model;
  DataPtr data;
  std::optional<ArmContactScreen> screen;  ///< asked first: mj_collision only for a model it does not screen
  PartClearance::Hint hint;                ///< the part's nearest point at the last question
};

CollisionChecker::CollisionChecker(const MujocoWorld& world, double margin_m, double torch_clearance_m)
    : state_(std::make_shared<State>()) {
  install_mujoco_handlers();
  state_->world = &world;
  state_->model.reset(mj_copyModel(nullptr, world.model()));
  mjModel* m = state_->model.get();
  for (int g = 0; g < m->ngeom; ++g) {
    if (world.geom_label(g) == Label::kPart) m->geom_contype[g] = m->geom_conaffinity[g] = 0;
    if (world.geom_label(g) == Label::kRobot) m->geom_margin[g] = margin_m;
    const char* name = mj_id2name(m, mjOBJ_GEOM, g);
    if (torch_clearance_m > 0 && name && std::strncmp(name, "torch_", 6) == 0) {
      double* size = m->geom_size + 3 * g;
      const int type = m->geom_type[g];
      if (type == mjGEOM_BOX || type == mjGEOM_ELLIPSOID)
        for (int k = 0; k < 3; ++k) size[k] += torch_clearance_m;
      else if (type == mjGEOM_CYLINDER || type == mjGEOM_CAPSULE)
        size[0] += torch_clearance_m, size[1] += torch_clearance_m;
      else if (type == mjGEOM_SPHERE)
        size[0] += torch_clearance_m;
      m->geom_rbound[g] += 2 * torch_clearance_m;  // the broad phase's bounding sphere
    }
  }
  state_->data.reset(mj_makeData(m));
  state_->screen.emplace(m, world.geom_labels());
}

void CollisionChecker::add_part(const Mesh& part_mesh, const Iso3& T_base_part, double margin_m,
                                double weld_margin_m) {
  // The checker asks only whether the clearance is under a margin: the search need look no farther than the
  // inside test does (beyond it every answer is outside and above the margins), which prunes more of the arm.
  state_->part.emplace(*state_->world, part_mesh, T_base_part,
                       std::max({margin_m, weld_margin_m, PartClearance::kInsideTestWithin_m}));
  state_->part_margin = margin_m;
  state_->weld_margin = weld_margin_m;
}

void CollisionChecker::place(const CellLayout& layout) {
  mjModel* m = state_->model.get();
  const auto set_pose = [&](const std::string& body, const Iso3& T) {
    const int b = state_->world->body(body);
    const Eigen::Quaterniond q(T.linear());
    for (int k = 0; k < 3; ++k) m->body_pos[3 * b + k] = T.translation()[k];
    m->body_quat[4 * b] = q.w(), m->body_quat[4 * b + 1] = q.x(), m->body_quat[4 * b + 2] = q.y(),
                     m->body_quat[4 * b + 3] = q.z();
  };
  set_pose("part", layout.T_base_part);
  for (size_t i = 0; i < layout.clamps.size(); ++i)
    set_pose("clamp" + std::to_string(i), layout.clamps[i].T_base_clamp);
  if (state_->part) state_->part->set_part_pose(layout.T_base_part);
}

std::string CollisionChecker::operator()(const JointVector& q, bool welding) const {
  const mjModel* m = state_->model.get();
  mjData* d = state_->data.get();
  const MujocoWorld& world = *state_->world;
  world.set_joints(m, d, q);
  // The screen's "clear" is mj_collision's, and the pair it finds touching is one mj_collision finds; a model
  // it does not screen goes to mj_collision.
  d->ncon = 0;
  ArmContactScreen::Touch touch;
  if (!state_->screen->clear(m, d, &touch)) {
    if (touch.arm_geom >= 0) return geom_name(m, touch.arm_geom) + " with " + geom_name(m, touch.other_geom);
    mj_collision(m, d);
  }
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    const bool r1 = world.geom_label(con.geom1) == Label::kRobot,
               r2 = world.geom_label(con.geom2) == Label::kRobot;
    if (!r1 && !r2) continue;
    if (r1 && r2 && con.dist > 0) continue;  // the margin is for the cell; the arm's own links may be close
    const int robot = r1 ? con.geom1 : con.geom2, other = r1 ? con.geom2 : con.geom1;
    const char* a = mj_id2name(m, mjOBJ_GEOM, robot);
    const char* b = mj_id2name(m, mjOBJ_GEOM, other);
    return std::string(a ? a : "robot") + " with " + (b ? b : "geom " + std::to_string(other));
  }
  if (state_->part) {
    std::string geom;
    if (state_->part->clearance(d, &geom, &state_->hint) <
        (welding ? state_->weld_margin : state_->part_margin))
      return geom + (welding ? " with the part while welding" : " with the part");
  }
  return "";
}

}  // namespace weldtwin
