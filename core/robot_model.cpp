#include "core/robot_model.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "core/error.hpp"

namespace weldtwin {
namespace {

Iso3 to_iso(const urdf::Pose& p) {
  Quat q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  return make_transform(Vec3(p.position.x, p.position.y, p.position.z), q.normalized().toRotationMatrix());
}

// Converts a URDF geometry into a primitive; meshes are not used by the robot model (primitives only).
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
                        "link '" + link + "' uses a mesh; the robot model takes box, cylinder, sphere");
  }
  if ((out.size.array() < 0.0).any()) throw input_error(source, "link '" + link + "' has a negative size");
  return out;
}

}  // namespace

RobotModel RobotModel::load(const std::string& urdf_path) {
  std::ifstream in(urdf_path);
  if (!in) throw input_error(urdf_path, "cannot open the robot description");
  std::stringstream ss;
  ss << in.rdbuf();
  return from_string(ss.str(), urdf_path);
}

namespace {

// How deep the XML's elements nest (comments, declarations and CDATA skipped; a rough count is enough):
// the XML parser under urdfdom recurses per level, so a file nested 100,000 deep overflowed the stack.
size_t xml_depth(const std::string& xml) {
  size_t depth = 0, deepest = 0;
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
    const size_t end = xml.find('>', i);
    if (end == std::string::npos) break;
    if (xml[end - 1] != '/') deepest = std::max(deepest, ++depth);
    i = end;
  }
  return deepest;
}

constexpr size_t kMaxUrdfDepth = 64;  // a robot description nests a handful of levels

}  // namespace

RobotModel RobotModel::from_string(const std::string& urdf_xml, const std::string& source) {
  if (urdf_xml.find_first_not_of(" \t\r\n") == std::string::npos) throw input_error(source, "empty URDF");
  if (const size_t depth = xml_depth(urdf_xml); depth > kMaxUrdfDepth)
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
    for (const auto& c : link->collision_array)
      if (c && c->geometry) out.collision.push_back(to_geometry(c->geometry, c->origin, source, link->name));
    for (const auto& v : link->visual_array) {
      if (!v || !v->geometry) continue;
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
