#include "sim/mujoco_world.hpp"

#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "core/error.hpp"
#include "core/files.hpp"
#include "core/mesh_file.hpp"
#include "sim/contact_prefilter.hpp"
#include "sim/convex_pieces.hpp"

namespace weldtwin {
namespace {

void throw_mujoco_error(const char* msg) {
  throw std::runtime_error(std::string("MuJoCo: ") + msg);
}
void ignore_mujoco_warning(const char*) {}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw input_error(path, "cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Writes numbers with enough digits that the MJCF round-trips doubles exactly.
class XmlNumbers {
 public:
  explicit XmlNumbers(std::ostringstream& os) : os_(os) { os_ << std::setprecision(17); }
  void vec(const char* attr, const double* v, int n) {
    os_ << ' ' << attr << "=\"";
    for (int i = 0; i < n; ++i) os_ << (i ? " " : "") << v[i];
    os_ << '"';
  }
  void pose(const Iso3& T) {
    const Quat q(T.linear());
    const double pos[3] = {T.translation().x(), T.translation().y(), T.translation().z()};
    const double quat[4] = {q.w(), q.x(), q.y(), q.z()};
    vec("pos", pos, 3);
    vec("quat", quat, 4);
  }

 private:
  std::ostringstream& os_;
};

void geom_xml(std::ostringstream& os, const std::string& name, const LinkGeometry& g) {
  XmlNumbers num(os);
  os << "<geom name=\"" << name << "\"";
  switch (g.type) {
    case LinkGeometry::Type::kBox: {
      const double s[3] = {g.size.x() / 2, g.size.y() / 2, g.size.z() / 2};
      os << " type=\"box\"";
      num.vec("size", s, 3);
      break;
    }
    case LinkGeometry::Type::kCylinder: {
      const double s[2] = {g.size.x(), g.size.y() / 2};
      os << " type=\"cylinder\"";
      num.vec("size", s, 2);
      break;
    }
    case LinkGeometry::Type::kSphere: {
      const double s[1] = {g.size.x()};
      os << " type=\"sphere\"";
      num.vec("size", s, 1);
      break;
    }
  }
  num.pose(g.T_link_geom);
  const double rgba[4] = {g.rgba[0], g.rgba[1], g.rgba[2], g.rgba[3]};
  num.vec("rgba", rgba, 4);
  os << "/>\n";
}

// MJCF names the world body "world"; a robot whose root link is so named (the vendor's) gets another.
std::string body_name(const RobotLink& link) {
  return link.name == "world" ? "robot_world" : link.name;
}

std::string mesh_asset_name(const RobotLink& link, size_t k) {
  return body_name(link) + "_mesh" + std::to_string(k);
}

std::string hull_asset_name(const RobotLink& link, size_t k, size_t piece) {
  return mesh_asset_name(link, k) + "_hull" + std::to_string(piece);
}

// Per link: each collision mesh's convex pieces (MuJoCo collides them in its place), and the visual meshes,
// read (mesh frame, scaled).
struct LinkMeshes {
  std::vector<std::vector<std::vector<Vec3>>> pieces;
  std::vector<Mesh> visual;
};

// The robot's meshes: collision meshes read and cut into convex pieces (MuJoCo draws the file itself, and
// reads STL and OBJ: a link with a collision mesh in another format is refused naming it), visual meshes read
// in any format load_robot_mesh reads (COLLADA too) and given to MuJoCo as vertices and faces.
std::vector<LinkMeshes> robot_meshes(const RobotModel& robot) {
  std::vector<LinkMeshes> out;
  for (const RobotLink& link : robot.links()) {
    LinkMeshes& lm = out.emplace_back();
    for (const LinkMesh& mesh : link.collision_meshes) {
      const std::string ext = lower_extension(mesh.path);
      if (ext != ".stl" && ext != ".obj")
        throw input_error(mesh.path, "link '" + link.name +
                                         "': collision meshes are read as STL or OBJ, not '" + ext + "'");
      Mesh m = load_mesh(mesh.path);
      for (Vec3& v : m.vertices) v = v.cwiseProduct(mesh.scale);
      lm.pieces.push_back(convex_pieces(m));
      if (lm.pieces.back().empty())
        throw input_error(mesh.path, "link '" + link.name + "': the mesh has no volume");
    }
    for (const LinkMesh& mesh : link.visual_meshes) {
      Mesh m = load_robot_mesh(mesh.path);
      for (Vec3& v : m.vertices) v = v.cwiseProduct(mesh.scale);
      lm.visual.push_back(std::move(m));
    }
  }
  return out;
}

std::string visual_asset_name(const RobotLink& link, size_t k) {
  return body_name(link) + "_visual" + std::to_string(k);
}

// The meshes as MJCF assets: the collision mesh's file (the part's clearance measured on it; drawn and
// ray-cast when the link has no visual mesh), its pieces' points (MuJoCo collides their hulls), and the
// visual meshes' vertices and faces (drawn and ray-cast).
std::string robot_mesh_assets(const RobotModel& robot, const std::vector<LinkMeshes>& meshes) {
  std::ostringstream os;
  XmlNumbers num(os);
  for (size_t l = 0; l < robot.links().size(); ++l) {
    const RobotLink& link = robot.links()[l];
    for (size_t k = 0; k < link.collision_meshes.size(); ++k) {
      const LinkMesh& mesh = link.collision_meshes[k];
      const double scale[3] = {mesh.scale.x(), mesh.scale.y(), mesh.scale.z()};
      os << "<mesh name=\"" << mesh_asset_name(link, k) << "\" file=\""
         << std::filesystem::absolute(mesh.path).lexically_normal().string() << "\"";
      num.vec("scale", scale, 3);
      os << "/>\n";
      const auto& hulls = meshes[l].pieces[k];
      for (size_t p = 0; p < hulls.size(); ++p) {
        std::vector<double> xyz;
        for (const Vec3& v : hulls[p]) xyz.insert(xyz.end(), {v.x(), v.y(), v.z()});
        os << "<mesh name=\"" << hull_asset_name(link, k, p) << "\"";
        num.vec("vertex", xyz.data(), static_cast<int>(xyz.size()));
        os << "/>\n";
      }
    }
    for (size_t k = 0; k < meshes[l].visual.size(); ++k) {
      const Mesh& mesh = meshes[l].visual[k];
      std::vector<double> xyz;
      for (const Vec3& v : mesh.vertices) xyz.insert(xyz.end(), {v.x(), v.y(), v.z()});
      os << "<mesh name=\"" << visual_asset_name(link, k) << "\"";
      num.vec("vertex", xyz.data(), static_cast<int>(xyz.size()));
      os << " face=\"";
      for (size_t f = 0; f < mesh.faces.size(); ++f)
        os << (f ? " " : "") << mesh.faces[f][0] << ' ' << mesh.faces[f][1] << ' ' << mesh.faces[f][2];
      os << "\"/>\n";
    }
  }
  return os.str();
}

void robot_body_xml(std::ostringstream& os, const RobotModel& robot, const std::vector<LinkMeshes>& meshes,
                    int index) {
  const RobotLink& link = robot.links()[static_cast<size_t>(index)];
  XmlNumbers num(os);
  os << "<body name=\"" << body_name(link) << "\"";
  num.pose(link.T_parent_joint);
  os << ">\n";
  if (link.has_inertial && link.inertial.mass_kg > 0.0) {
    // fullinertia excludes an orientation: express the tensor in the link's axes.
    const Mat3& R = link.inertial.T_link_com.linear();
    const Mat3 I = R * link.inertial.inertia * R.transpose();
    const double full[6] = {I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)};
    const Vec3 c = link.inertial.T_link_com.translation();
    const double pos[3] = {c.x(), c.y(), c.z()};
    os << "<inertial";
    num.vec("pos", pos, 3);
    os << " mass=\"" << link.inertial.mass_kg << "\"";
    num.vec("fullinertia", full, 6);
    os << "/>\n";
  }
  if (link.q_index >= 0) {
    const double axis[3] = {link.axis.x(), link.axis.y(), link.axis.z()};
    const double range[2] = {link.lower_rad, link.upper_rad};
    os << "<joint name=\"" << link.joint_name << "\" type=\"hinge\"";
    num.vec("axis", axis, 3);
    num.vec("range", range, 2);
    os << " limited=\"true\" damping=\"2\" armature=\"0.05\"/>\n";
  }
  // Collision geometry is what MuJoCo keeps of a URDF; the visual colours are carried over where they pair
  // up.
  for (size_t g = 0; g < link.collision.size(); ++g) {
    LinkGeometry geom = link.collision[g];
    if (g < link.visual.size()) geom.rgba = link.visual[g].rgba;
    geom_xml(os, link.name + "_" + std::to_string(g), geom);
  }
  // MuJoCo collides a collision mesh's convex pieces (kCollisionOnlyGroup); the mesh itself is drawn and
  // ray-cast unless the link has visual meshes (then kClearanceOnlyGroup); the visual meshes are drawn and
  // ray-cast, never collided.
  const LinkMeshes& lm = meshes[static_cast<size_t>(index)];
  for (size_t k = 0; k < link.collision_meshes.size(); ++k) {
    os << "<geom name=\"" << mesh_asset_name(link, k) << "\" type=\"mesh\" mesh=\""
       << mesh_asset_name(link, k) << "\" contype=\"0\" conaffinity=\"0\" group=\""
       << (lm.visual.empty() ? 0 : kClearanceOnlyGroup) << "\"";
    num.pose(link.collision_meshes[k].T_link_mesh);
    os << " rgba=\"0.86 0.87 0.88 1\"/>\n";
    for (size_t p = 0; p < lm.pieces[k].size(); ++p) {
      os << "<geom name=\"" << hull_asset_name(link, k, p) << "\" type=\"mesh\" mesh=\""
         << hull_asset_name(link, k, p) << "\" group=\"" << kCollisionOnlyGroup << "\"";
      num.pose(link.collision_meshes[k].T_link_mesh);
      os << " rgba=\"0.9 0.5 0.2 0.4\"/>\n";
    }
  }
  for (size_t k = 0; k < lm.visual.size(); ++k) {
    os << "<geom name=\"" << visual_asset_name(link, k) << "\" type=\"mesh\" mesh=\""
       << visual_asset_name(link, k) << "\" contype=\"0\" conaffinity=\"0\" group=\"" << kVisualGroup << "\"";
    num.pose(link.visual_meshes[k].T_link_mesh);
    os << " rgba=\"0.86 0.87 0.88 1\"/>\n";
  }
  for (size_t c = 0; c < robot.links().size(); ++c)
    if (robot.links()[c].parent == index) robot_body_xml(os, robot, meshes, static_cast<int>(c));
  os << "</body>\n";
}

void box_geom(std::ostringstream& os, const std::string& name, const Vec3& center, const Vec3& half,
              const Mat3& R = Mat3::Identity(), const char* rgba = "0.15 0.35 0.75 1") {
  XmlNumbers num(os);
  os << "<geom name=\"" << name << "\" type=\"box\"";
  const double s[3] = {half.x(), half.y(), half.z()};
  num.vec("size", s, 3);
  num.pose(make_transform(center, R));
  os << " rgba=\"" << rgba << "\"/>\n";
}

void cylinder_geom(std::ostringstream& os, const std::string& name, const Vec3& center, double radius,
                   double half_height, const char* rgba) {
  XmlNumbers num(os);
  os << "<geom name=\"" << name << "\" type=\"cylinder\"";
  const double s[2] = {radius, half_height};
  num.vec("size", s, 2);
  const double pos[3] = {center.x(), center.y(), center.z()};
  num.vec("pos", pos, 3);
  os << " rgba=\"" << rgba << "\"/>\n";
}

// A horizontal toggle clamp in the clamp frame (see ClampPlacement): rubber pad on the part, spindle, arm,
// post and base block on the table, handle.
void clamp_xml(std::ostringstream& os, int index, const ClampPlacement& c) {
  const std::string n = "clamp" + std::to_string(index);
  const double h = c.grip_height_m;
  XmlNumbers num(os);
  os << "<body name=\"" << n << "\"";
  num.pose(c.T_base_clamp);
  os << ">\n";
  cylinder_geom(os, n + "_pad", Vec3(0, 0, 0.004), ClampDims::kPadRadius, 0.004, "0.1 0.1 0.1 1");
  // A low-profile hold-down: the arm 28 mm above the pad, so that a torch at 45 deg passes over it.
  cylinder_geom(os, n + "_spindle", Vec3(0, 0, 0.016), 0.005, 0.008, "0.75 0.75 0.72 1");
  box_geom(os, n + "_arm", Vec3(0.048, 0, 0.028), Vec3(0.052, 0.012, 0.006));
  box_geom(os, n + "_post", Vec3(0.09, 0, 0.5 * (0.034 - h)), Vec3(0.012, 0.015, 0.5 * (h + 0.034)));
  box_geom(os, n + "_base", Vec3(0.5 * (ClampDims::kBaseStart + ClampDims::kBaseEnd), 0, -h + 0.006),
           Vec3(0.5 * (ClampDims::kBaseEnd - ClampDims::kBaseStart), ClampDims::kHalfWidth, 0.006));
  box_geom(os, n + "_handle", Vec3(0.165, 0, 0.056), Vec3(0.065, 0.009, 0.009),
           Eigen::AngleAxisd(-0.35, Vec3::UnitY()).toRotationMatrix(), "0.85 0.1 0.1 1");
  os << "</body>\n";
}

void clutter_xml(std::ostringstream& os, int index, const ClutterItem& item, double table_top_z_m) {
  const std::string n = "clutter" + std::to_string(index);
  XmlNumbers num(os);
  os << "<body name=\"" << n << "\"";
  num.pose(planar_pose(item.x_m, item.y_m, table_top_z_m + 0.5 * item.size_m.z(), item.yaw_rad));
  os << ">\n";
  if (item.type == ClutterItem::Type::kBox) {
    box_geom(os, n + "_box", Vec3::Zero(), 0.5 * item.size_m, Mat3::Identity(), "0.55 0.45 0.3 1");
  } else {
    cylinder_geom(os, n + "_cyl", Vec3::Zero(), 0.5 * item.size_m.x(), 0.5 * item.size_m.z(),
                  "0.3 0.5 0.3 1");
  }
  os << "</body>\n";
}

}  // namespace

const char* label_name(Label label) {
  switch (label) {
    case Label::kNone:
      return "none";
    case Label::kPart:
      return "part";
    case Label::kTable:
      return "table";
    case Label::kClamp:
      return "clamp";
    case Label::kRobot:
      return "robot";
    case Label::kOther:
      return "other";
  }
  return "?";
}

void install_mujoco_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = throw_mujoco_error;
    mju_user_warning = ignore_mujoco_warning;
  });
  install_contact_prefilter();
}

ModelPtr load_mjcf(const std::string& xml, const std::string& base_dir, const std::string& source) {
  install_mujoco_handlers();
  // The XML goes through MuJoCo's virtual file system; assets with absolute paths are read from disk.
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const std::string name = (std::filesystem::path(base_dir) / "weldtwin_cell.xml").string();
  if (mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(xml.size())) != 0)
    throw std::runtime_error("MuJoCo VFS is full");
  const int slot = mj_findFileVFS(vfs.get(), name.c_str());
  std::memcpy(vfs->filedata[slot], xml.data(), xml.size());
  char error[1024] = "";
  mjModel* m = mj_loadXML(name.c_str(), vfs.get(), error, sizeof(error));
  mj_deleteVFS(vfs.get());
  if (!m) throw input_error(source, std::string("MuJoCo cannot load the cell: ") + error);
  return ModelPtr(m);
}

std::string compose_cell_mjcf(const CellSpec& cell, const PartSpec& part, const RobotModel& robot,
                              const CellLayout& layout) {
  std::string env = read_text(cell.environment_mjcf);
  const size_t world_end = env.rfind("</worldbody>");
  if (world_end == std::string::npos) throw input_error(cell.environment_mjcf, "MJCF has no <worldbody>");

  std::ostringstream bodies;
  bodies << "<!-- added by weldtwin from " << cell.source << " -->\n";
  const std::vector<LinkMeshes> meshes = robot_meshes(robot);
  robot_body_xml(bodies, robot, meshes, 0);
  XmlNumbers num(bodies);
  bodies << "<body name=\"part\"";
  num.pose(layout.T_base_part);
  bodies << ">\n<geom name=\"part\" type=\"mesh\" mesh=\"part_mesh\" rgba=\"0.62 0.64 0.68 1\"/>\n</body>\n";
  for (size_t i = 0; i < layout.clamps.size(); ++i) clamp_xml(bodies, static_cast<int>(i), layout.clamps[i]);
  for (size_t i = 0; i < layout.clutter.size(); ++i)
    clutter_xml(bodies, static_cast<int>(i), layout.clutter[i], cell.table.top_z_m);
  env.insert(world_end, bodies.str());

  // The arm's servos (gains are set by whoever drives them: the replay tunes them to the arm's inertia).
  std::ostringstream act;
  act << "<actuator>\n";
  for (const auto& joint : robot.joint_names())
    act << "<position name=\"servo_" << joint << "\" joint=\"" << joint << "\" kp=\"1\"/>\n"
        << "<velocity name=\"damper_" << joint << "\" joint=\"" << joint << "\" kv=\"1\"/>\n";
  act << "</actuator>\n<contact>\n";
  // Neighbouring links overlap at their joints by construction; MuJoCo only filters parent-child pairs
  // below a moving body, and the first link hangs from the fixed base.
  for (const RobotLink& link : robot.links())
    if (link.parent >= 0)
      act << "<exclude body1=\"" << body_name(robot.links()[static_cast<size_t>(link.parent)])
          << "\" body2=\"" << body_name(link) << "\"/>\n";
  act << "</contact>\n";
  const size_t model_end = env.rfind("</mujoco>");
  if (model_end == std::string::npos) throw input_error(cell.environment_mjcf, "MJCF has no </mujoco>");
  env.insert(model_end, act.str());

  const std::string mesh = "<mesh name=\"part_mesh\" file=\"" +
                           std::filesystem::absolute(part.mesh_path).lexically_normal().string() + "\"/>\n" +
                           robot_mesh_assets(robot, meshes);
  const size_t asset_end = env.find("</asset>");
  if (asset_end != std::string::npos) {
    env.insert(asset_end, mesh);
  } else {
    const size_t world = env.find("<worldbody");
    env.insert(world, "<asset>\n" + mesh + "</asset>\n");
  }
  return env;
}

MujocoWorld::MujocoWorld(const CellSpec& cell, const PartSpec& part, const RobotModel& robot,
                         const CellLayout& layout)
    : mjcf_(compose_cell_mjcf(cell, part, robot, layout)), robot_(robot) {
  model_ = load_mjcf(mjcf_, std::filesystem::path(cell.environment_mjcf).parent_path().string(),
                     cell.environment_mjcf);
  data_.reset(mj_makeData(model_.get()));
  const mjModel* m = model_.get();
  for (const auto& name : robot.joint_names()) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j < 0) throw std::logic_error("composed cell lost joint " + name);
    qpos_adr_.push_back(m->jnt_qposadr[j]);
  }
  body_link_.assign(static_cast<size_t>(m->nbody), -1);
  for (size_t i = 0; i < robot.links().size(); ++i)
    body_link_[static_cast<size_t>(body(body_name(robot.links()[i])))] = static_cast<int>(i);
  const int robot_root = body(body_name(robot.links().front()));
  geom_labels_.resize(static_cast<size_t>(m->ngeom), Label::kOther);
  placed_.assign(static_cast<size_t>(m->ngeom), 0);
  const int part_body = body("part");
  for (int g = 0; g < m->ngeom; ++g) {
    const int root = m->body_rootid[m->geom_bodyid[g]];
    const char* name = mj_id2name(m, mjOBJ_BODY, root);
    const std::string n = name ? name : "";
    // compose_cell_mjcf adds the layout's bodies last, the part's first: MuJoCo numbers bodies, and geoms by
    // body, in the order they come, so the geoms before them keep their ids in every layout.
    placed_[static_cast<size_t>(g)] = root >= part_body;
    Label& label = geom_labels_[static_cast<size_t>(g)];
    if (root == robot_root) {
      label = Label::kRobot;
    } else if (n == "part") {
      label = Label::kPart;
    } else if (n.rfind("clamp", 0) == 0) {
      label = Label::kClamp;
    } else if (n.rfind("table", 0) == 0) {
      label = Label::kTable;
    }
  }
  mj_kinematics(m, data_.get());
}

void MujocoWorld::set_joints(const mjModel* m, mjData* d, const JointVector& q) const {
  for (size_t i = 0; i < qpos_adr_.size(); ++i) d->qpos[qpos_adr_[i]] = q[static_cast<int>(i)];
  mj_kinematics(m, d);
}

int MujocoWorld::body(const std::string& name) const {
  const int id = mj_name2id(model_.get(), mjOBJ_BODY, name.c_str());
  if (id < 0) throw std::out_of_range("cell has no body '" + name + "'");
  return id;
}

}  // namespace weldtwin
