#include "core/robot_model.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/error.hpp"

namespace weldtwin {
namespace {

Iso3 to_iso(const urdf::Pose& p) {
  Quat q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  return make_transform(Vec3(p.position.x, p.position.y, p.position.z), q.normalized().toRotationMatrix());
}

// Converts a URDF primitive (box, cylinder, sphere; meshes are kept apart, as LinkMesh).
LinkGeometry to_geometry(const urdf::GeometrySharedPtr& g, const urdf::Pose& origin,
                         const std::string& source, const std::string& link) {
  LinkGeometry out;
  out.T_link_geom = to_iso(origin);
  switch (g->type) {
    case urdf::Geometry::BOX: {
      auto b = std::static_pointer_cast<urdf::Box>(g);
      out.type = LinkGeometry::Type::kBox;
      out.size = Vec3(b->dim.x, b->dim.y, b->dim.z);
      break;
    }
    case urdf::Geometry::CYLINDER: {
      auto c = std::static_pointer_cast<urdf::Cylinder>(g);
      out.type = LinkGeometry::Type::kCylinder;
      out.size = Vec3(c->radius, c->length, 0.0);
      break;
    }
    case urdf::Geometry::SPHERE: {
      auto s = std::static_pointer_cast<urdf::Sphere>(g);
      out.type = LinkGeometry::Type::kSphere;
      out.size = Vec3(s->radius, 0.0, 0.0);
      break;
    }
    default:
      throw input_error(source,
                        "link '" + link + "' uses a geometry that is not a box, cylinder, sphere or mesh");
  }
  if ((out.size.array() < 0.0).any()) throw input_error(source, "link '" + link + "' has a negative size");
  return out;
}

}  // namespace

RobotModel RobotModel::load(const std::string& urdf_path, const std::vector<std::string>& package_dirs) {
  std::ifstream in(urdf_path);
  if (!in) throw input_error(urdf_path, "cannot open the robot description");
  std::stringstream ss;
  ss << in.rdbuf();
  return from_string(ss.str(), urdf_path, package_dirs);
}

namespace {

// What a rough scan of the XML tells (comments, declarations and CDATA skipped): how deep its elements nest
// (the XML parser under urdfdom recurses per level, so a file nested 100,000 deep overflowed the stack), and
// every element's name with how often it appears (to name the elements URDF does not define).
struct XmlOutline {
  size_t deepest = 0;
  std::map<std::string, int> elements;
};

XmlOutline xml_outline(const std::string& xml) {
  XmlOutline out;
  size_t depth = 0;
  for (size_t i = xml.find('<'); i != std::string::npos; i = xml.find('<', i + 1)) {
    if (i + 1 >= xml.size()) break;
    const char c = xml[i + 1];
    if (c == '!' || c == '?') {
      const size_t end = xml.compare(i, 4, "<!--") == 0 ? xml.find("-->", i) : xml.find('>', i);
      if (end == std::string::npos) break;
      i = end;
      continue;
    }
    if (c == '/') {
      depth -= depth > 0;
      continue;
    }
    size_t name_end = i + 1;
    while (name_end < xml.size() &&
           (std::isalnum(static_cast<unsigned char>(xml[name_end])) || xml[name_end] == '_' ||
            xml[name_end] == ':' || xml[name_end] == '-' || xml[name_end] == '.'))
      ++name_end;
    if (name_end > i + 1) ++out.elements[xml.substr(i + 1, std::min<size_t>(name_end - i - 1, 64))];
    const size_t end = xml.find('>', i);
    if (end == std::string::npos) break;
    if (xml[end - 1] != '/') out.deepest = std::max(out.deepest, ++depth);
    i = end;
  }
  return out;
}

constexpr size_t kMaxUrdfDepth = 64;  // a robot description nests a handful of levels

// The elements a URDF may hold (the format's own, and the transmission and Gazebo blocks tools add).
const std::set<std::string>& urdf_elements() {
  // clang-format off
  static const std::set<std::string> e = {
      "robot", "link", "joint", "inertial", "origin", "mass", "inertia", "visual", "collision", "geometry", "box",
      "cylinder", "sphere", "mesh", "capsule", "material", "color", "texture", "parent", "child", "axis", "limit",
      "dynamics", "calibration", "mimic", "safety_controller", "transmission", "type", "actuator",
      "hardwareInterface", "mechanicalReduction", "gazebo", "plugin", "version"};
  // clang-format on
  return e;
}

// The folder of ROS package `name`: beside or above `from` (a folder named so, holding package.xml), in one
// of `dirs` (the folder itself, or a folder holding it), or in ROS_PACKAGE_PATH's. "" when there is none.
std::string package_folder(const std::string& name, const std::filesystem::path& from,
                           std::vector<std::string> dirs) {
  namespace fs = std::filesystem;
  std::error_code ec;
  auto is_package = [&](const fs::path& d) {
    return d.filename() == name && fs::is_regular_file(d / "package.xml", ec);
  };
  for (fs::path d = fs::absolute(from, ec); !d.empty(); d = d.parent_path()) {
    if (is_package(d)) return d.string();
    if (is_package(d / name)) return (d / name).string();
    if (d == d.parent_path()) break;
  }
  if (const char* env = std::getenv("ROS_PACKAGE_PATH")) {
    std::stringstream ss(env);
    for (std::string item; std::getline(ss, item, ':');)
      if (!item.empty()) dirs.push_back(item);
  }
  for (const std::string& dir : dirs) {
    if (is_package(dir)) return dir;
    if (is_package(fs::path(dir) / name)) return (fs::path(dir) / name).string();
  }
  return "";
}

}  // namespace

std::string mesh_file(const std::string& filename, const std::string& source, const std::string& link,
                      const std::vector<std::string>& package_dirs) {
  namespace fs = std::filesystem;
  const fs::path urdf_dir = fs::path(source).parent_path();
  std::string path;
  if (filename.rfind("package://", 0) == 0) {
    const std::string rest = filename.substr(10);
    const size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    const std::string folder = package_folder(package, urdf_dir, package_dirs);
    if (folder.empty())
      throw input_error(source,
                        "link '" + link + "': mesh " + filename + ": package '" + package +
                            "' not found (a folder of that name with its package.xml, beside or above "
                            "the URDF, or on ROS_PACKAGE_PATH)");
    path = slash == std::string::npos ? folder : (fs::path(folder) / rest.substr(slash + 1)).string();
  } else if (filename.rfind("file://", 0) == 0) {
    path = filename.substr(7);
  } else {
    path = fs::path(filename).is_absolute() ? filename : (urdf_dir / filename).string();
  }
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw input_error(source, "link '" + link + "': mesh " + filename + " is not there (" + path + ")");
  return path;
}

namespace {

LinkMesh to_mesh(const urdf::GeometrySharedPtr& g, const urdf::Pose& origin, const std::string& source,
                 const std::string& link, const std::vector<std::string>& package_dirs) {
  const auto m = std::static_pointer_cast<urdf::Mesh>(g);
  LinkMesh out;
  out.path = mesh_file(m->filename, source, link, package_dirs);
  out.scale = Vec3(m->scale.x, m->scale.y, m->scale.z);
  out.T_link_mesh = to_iso(origin);
  if (!(out.scale.array() > 0.0).all() || !out.scale.allFinite())
    throw input_error(source, "link '" + link + "': a mesh scale that is not positive");
  return out;
}

}  // namespace

RobotModel RobotModel::from_string(const std::string& urdf_xml, const std::string& source,
                                   const std::vector<std::string>& package_dirs) {
  if (urdf_xml.find_first_not_of(" \t\r\n") == std::string::npos) throw input_error(source, "empty URDF");
  const XmlOutline outline = xml_outline(urdf_xml);
  if (const size_t depth = outline.deepest; depth > kMaxUrdfDepth)
    throw input_error(source, "elements nested " + std::to_string(depth) +
                                  " deep (a robot description has a "
                                  "few levels): not a URDF");
  // urdfdom reports parse errors on stderr through console_bridge; weldtwin reports them itself, in one line.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  urdf::ModelInterfaceSharedPtr urdf = urdf::parseURDF(urdf_xml);
  if (!urdf) throw input_error(source, "not a valid URDF (urdfdom could not parse it)");
  urdf::LinkConstSharedPtr root = urdf->getRoot();
  if (!root) throw input_error(source, "URDF has no root link");

  RobotModel model;
  model.name_ = urdf->getName();
  for (const auto& [name, count] : outline.elements)
    if (!urdf_elements().count(name))
      model.notes_.push_back("ignored <" + name + ">" +
                             (count > 1 ? " (" + std::to_string(count) + " times)" : "") +
                             ": not an element of URDF");
  // Depth-first from the root keeps parents before children.
  std::vector<std::pair<urdf::LinkConstSharedPtr, int>> stack{{root, -1}};
  while (!stack.empty()) {
    auto [link, parent] = stack.back();
    stack.pop_back();
    RobotLink out;
    out.name = link->name;
    out.parent = parent;
    if (auto joint = link->parent_joint) {
      out.joint_name = joint->name;
      out.T_parent_joint = to_iso(joint->parent_to_joint_origin_transform);
      switch (joint->type) {
        case urdf::Joint::FIXED:
          break;
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS: {
          Vec3 axis(joint->axis.x, joint->axis.y, joint->axis.z);
          if (axis.norm() < 1e-12) throw input_error(source, "joint '" + joint->name + "' has a zero axis");
          out.axis = axis.normalized();
          out.q_index = static_cast<int>(model.joint_names_.size());
          model.joint_names_.push_back(joint->name);
          if (joint->type == urdf::Joint::CONTINUOUS || !joint->limits) {
            out.lower_rad = -kPi;
            out.upper_rad = kPi;
          } else {
            out.lower_rad = joint->limits->lower;
            out.upper_rad = joint->limits->upper;
            out.velocity_rad_s = joint->limits->velocity;
          }
          if (out.lower_rad >= out.upper_rad)
            throw input_error(source, "joint '" + joint->name + "' has lower limit >= upper limit");
          break;
        }
        default:
          throw input_error(source, "joint '" + joint->name + "' is neither revolute nor fixed");
      }
    }
    for (const auto& c : link->collision_array) {
      if (!c || !c->geometry) continue;
      if (c->geometry->type == urdf::Geometry::MESH)
        out.collision_meshes.push_back(to_mesh(c->geometry, c->origin, source, link->name, package_dirs));
      else
        out.collision.push_back(to_geometry(c->geometry, c->origin, source, link->name));
    }
    for (const auto& v : link->visual_array) {
      if (!v || !v->geometry) continue;
      if (v->geometry->type == urdf::Geometry::MESH) {
        out.visual_meshes.push_back(to_mesh(v->geometry, v->origin, source, link->name, package_dirs));
        continue;
      }
      LinkGeometry g = to_geometry(v->geometry, v->origin, source, link->name);
      if (v->material)
        g.rgba << v->material->color.r, v->material->color.g, v->material->color.b, v->material->color.a;
      out.visual.push_back(g);
    }
    if (auto in = link->inertial) {
      out.has_inertial = true;
      out.inertial.T_link_com = to_iso(in->origin);
      out.inertial.mass_kg = in->mass;
      out.inertial.inertia << in->ixx, in->ixy, in->ixz, in->ixy, in->iyy, in->iyz, in->ixz, in->iyz, in->izz;
    }
    const int index = static_cast<int>(model.links_.size());
    model.links_.push_back(std::move(out));
    // Children in reverse so they come out of the stack in file order.
    for (auto it = link->child_links.rbegin(); it != link->child_links.rend(); ++it)
      stack.push_back({*it, index});
  }

  if (model.dof() != 6)
    throw input_error(source,
                      "expected a 6-joint arm, found " + std::to_string(model.dof()) + " revolute joints");
  // Acceleration limits are not part of URDF; these are the Aubo i5's published figures (J1-J3, J4-J6).
  const double accel[6] = {17.2, 17.2, 17.2, 20.7, 20.7, 20.7};
  for (const auto& link : model.links_) {
    if (link.q_index < 0) continue;
    model.lower_[link.q_index] = link.lower_rad;
    model.upper_[link.q_index] = link.upper_rad;
    model.max_velocity_[link.q_index] = link.velocity_rad_s;
    model.max_acceleration_[link.q_index] = accel[link.q_index];
  }
  return model;
}

int RobotModel::link_index(const std::string& link_name) const {
  for (size_t i = 0; i < links_.size(); ++i)
    if (links_[i].name == link_name) return static_cast<int>(i);
  return -1;
}

int RobotModel::require_link(const std::string& link_name) const {
  const int i = link_index(link_name);
  if (i < 0) throw std::out_of_range("robot '" + name_ + "' has no link '" + link_name + "'");
  return i;
}

void RobotModel::forward_kinematics(const JointVector& q, std::vector<Iso3>& T_base_link) const {
  T_base_link.resize(links_.size());
  for (size_t i = 0; i < links_.size(); ++i) {
    const RobotLink& l = links_[i];
    Iso3 T = l.parent < 0 ? Iso3::Identity() : T_base_link[static_cast<size_t>(l.parent)] * l.T_parent_joint;
    if (l.q_index >= 0) T.rotate(Eigen::AngleAxisd(q[l.q_index], l.axis));
    T_base_link[i] = T;
  }
}

Iso3 RobotModel::forward_kinematics(const JointVector& q, int link) const {
  // Walk up to the root, then compose downwards.
  int chain[64];
  int n = 0;
  for (int i = link; i >= 0; i = links_[static_cast<size_t>(i)].parent) chain[n++] = i;
  Iso3 T = Iso3::Identity();
  for (int k = n - 1; k >= 0; --k) {
    const RobotLink& l = links_[static_cast<size_t>(chain[k])];
    if (l.parent >= 0) T = T * l.T_parent_joint;
    if (l.q_index >= 0) T.rotate(Eigen::AngleAxisd(q[l.q_index], l.axis));
  }
  return T;
}

namespace {

// R := R * Rot(axis, angle); about z (every joint of our arms) on two columns only.
void turn(Mat3& R, const Vec3& axis, double angle) {
  if (axis == Vec3::UnitZ()) {
    const double c = std::cos(angle), s = std::sin(angle);
    const Vec3 x = R.col(0), y = R.col(1);
    R.col(0) = c * x + s * y;
    R.col(1) = c * y - s * x;
  } else {
    R = R * Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  }
}

}  // namespace

Iso3 RobotModel::forward_kinematics(const JointVector& q, int link, ChainCache& cache) const {
  if (link < 0 || link >= static_cast<int>(links_.size()))
    throw std::out_of_range("forward_kinematics: no link " + std::to_string(link) + " in " + name_);
  const bool fresh = cache.link != link;
  if (fresh) {
    cache = ChainCache();
    cache.link = link;
    for (int i = link; i >= 0; i = links_.at(static_cast<size_t>(i)).parent) cache.chain.push_back(i);
    std::reverse(cache.chain.begin(), cache.chain.end());
    cache.R.assign(cache.chain.size() + 1, Mat3::Identity());
    cache.p.assign(cache.chain.size() + 1, Vec3::Zero());
  }
  const size_t n = cache.chain.size();
  // The last link whose joint changed bounds what must be recomputed; a fresh cache recomputes everything.
  size_t dirty = fresh ? n - 1 : 0;
  bool any = fresh;
  for (size_t k = 0; !fresh && k < n; ++k) {
    const int j = links_[static_cast<size_t>(cache.chain[k])].q_index;
    if (j >= 0 && !(q[j] == cache.q[j])) {
      dirty = k;
      any = true;
    }
  }
  if (any) {
    for (size_t k = dirty + 1; k-- > 0;) {
      // S_k = A_k Rot_k(q) S_{k+1}; the root is the base frame itself.
      const RobotLink& l = links_[static_cast<size_t>(cache.chain[k])];
      const Iso3 A = l.parent < 0 ? Iso3::Identity() : l.T_parent_joint;
      Mat3 R = A.linear();
      if (l.q_index >= 0) turn(R, l.axis, q[l.q_index]);
      cache.p[k] = A.translation() + R * cache.p[k + 1];
      cache.R[k] = R * cache.R[k + 1];
    }
    cache.q = q;
  }
  return make_transform(cache.p[0], cache.R[0]);
}

RobotModel RobotModel::with_mount_offset(const std::string& link_name, const Iso3& delta) const {
  RobotModel copy = *this;
  RobotLink& l = copy.links_[static_cast<size_t>(require_link(link_name))];
  l.T_parent_joint = l.T_parent_joint * delta;
  return copy;
}

bool RobotModel::within_limits(const JointVector& q) const {
  return ((q - lower_).array() >= 0.0).all() && ((upper_ - q).array() >= 0.0).all();
}

}  // namespace weldtwin
