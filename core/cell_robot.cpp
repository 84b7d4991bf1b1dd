#include "core/cell_robot.hpp"

#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "core/error.hpp"

namespace weldtwin {
namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw input_error(path, "cannot open the robot description");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string triple(const Vec3& v) {
  return num(v.x()) + " " + num(v.y()) + " " + num(v.z());
}

std::string origin_xml(const UrdfOrigin& o) {
  return "<origin xyz=\"" + triple(o.xyz_m) + "\" rpy=\"" + triple(o.rpy_rad) + "\"/>";
}

std::string geometry_xml(const ToolingShape& s) {
  switch (s.type) {
    case LinkGeometry::Type::kBox:
      return "<box size=\"" + triple(s.size_m) + "\"/>";
    case LinkGeometry::Type::kCylinder:
      return "<cylinder radius=\"" + num(s.size_m.x()) + "\" length=\"" + num(s.size_m.y()) + "\"/>";
    case LinkGeometry::Type::kSphere:
      return "<sphere radius=\"" + num(s.size_m.x()) + "\"/>";
  }
  return "";
}

// A uniform solid's volume [m^3] and its inertia per unit mass about its centre, in its own axes [m^2].
void solid(const ToolingShape& s, double& volume, Mat3& unit_inertia) {
  const Vec3& d = s.size_m;
  unit_inertia.setZero();
  switch (s.type) {
    case LinkGeometry::Type::kBox:
      volume = d.x() * d.y() * d.z();
      unit_inertia.diagonal() =
          Vec3(d.y() * d.y() + d.z() * d.z(), d.x() * d.x() + d.z() * d.z(), d.x() * d.x() + d.y() * d.y()) /
          12;
      break;
    case LinkGeometry::Type::kCylinder: {
      const double r = d.x(), h = d.y(), side = (3 * r * r + h * h) / 12;
      volume = kPi * r * r * h;
      unit_inertia.diagonal() = Vec3(side, side, r * r / 2);
      break;
    }
    case LinkGeometry::Type::kSphere:
      volume = 4.0 / 3.0 * kPi * d.x() * d.x() * d.x();
      unit_inertia.diagonal().setConstant(0.4 * d.x() * d.x());
      break;
  }
}

// The link's mass spread over its shapes as uniform solids of one density: centre of mass and inertia.
std::string inertial_xml(const ToolingLink& link) {
  if (link.mass_kg <= 0.0 || link.shapes.empty()) return "";
  double total = 0.0;
  Vec3 com = Vec3::Zero();
  std::vector<double> volumes(link.shapes.size());
  std::vector<Mat3> unit(link.shapes.size());
  for (size_t k = 0; k < link.shapes.size(); ++k) {
    solid(link.shapes[k], volumes[k], unit[k]);
    total += volumes[k];
    com += volumes[k] * link.shapes[k].origin.xyz_m;
  }
  com /= total;
  Mat3 I = Mat3::Zero();
  for (size_t k = 0; k < link.shapes.size(); ++k) {
    const ToolingShape& s = link.shapes[k];
    const double m = link.mass_kg * volumes[k] / total;
    const Mat3 R = s.origin.transform().linear();
    const Vec3 r = s.origin.xyz_m - com;
    I += m * (R * unit[k] * R.transpose()) + m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  return "<inertial><origin xyz=\"" + triple(com) + "\"/><mass value=\"" + num(link.mass_kg) +
         "\"/><inertia ixx=\"" + num(I(0, 0)) + "\" ixy=\"" + num(I(0, 1)) + "\" ixz=\"" + num(I(0, 2)) +
         "\" iyy=\"" + num(I(1, 1)) + "\" iyz=\"" + num(I(1, 2)) + "\" izz=\"" + num(I(2, 2)) +
         "\"/></inertial>";
}

std::string tooling_xml(const ToolingLink& link) {
  std::ostringstream os;
  os << "  <link name=\"" << link.link << "\">" << inertial_xml(link) << "\n";
  for (size_t k = 0; k < link.shapes.size(); ++k) {
    const ToolingShape& s = link.shapes[k];
    const Eigen::Vector4d& c = s.rgba;
    os << "    <visual>" << origin_xml(s.origin) << "<geometry>" << geometry_xml(s)
       << "</geometry><material name=\"" << link.link << "_" << k << "\"><color rgba=\"" << num(c[0]) << " "
       << num(c[1]) << " " << num(c[2]) << " " << num(c[3]) << "\"/></material></visual>\n"
       << "    <collision>" << origin_xml(s.origin) << "<geometry>" << geometry_xml(s)
       << "</geometry></collision>\n";
  }
  os << "  </link>\n  <joint name=\"" << link.link << "_joint\" type=\"fixed\"><parent link=\"" << link.parent
     << "\"/><child link=\"" << link.link << "\"/>" << origin_xml(link.origin) << "</joint>\n";
  return os.str();
}

}  // namespace

std::string cell_robot_urdf(const CellSpec& cell) {
  std::string xml = read_file(cell.robot_urdf);
  if (cell.tooling.empty()) return xml;
  const size_t end = xml.rfind("</robot>");
  if (end == std::string::npos) throw input_error(cell.robot_urdf, "has no </robot>: not a URDF");
  // The names the robot already has, to tell a clash here rather than as urdfdom's "not unique".
  const RobotModel bare = RobotModel::from_string(xml, cell.robot_urdf, cell.robot_package_dirs);
  std::set<std::string> links, joints;
  for (const RobotLink& l : bare.links()) links.insert(l.name), joints.insert(l.joint_name);
  std::string added = "  <!-- the cell's tooling, from " + cell.source + " -->\n";
  for (const ToolingLink& t : cell.tooling) {
    if (!links.count(t.parent))
      throw input_error(cell.source, "tooling link '" + t.link + "': parent link '" + t.parent +
                                         "' is neither in " + cell.robot_urdf +
                                         " nor an earlier tooling link");
    if (!links.insert(t.link).second)
      throw input_error(cell.source,
                        "tooling link '" + t.link + "': the robot already has a link of that name");
    if (!joints.insert(t.link + "_joint").second)
      throw input_error(cell.source, "tooling link '" + t.link + "': the robot already has a joint named '" +
                                         t.link + "_joint'");
    added += tooling_xml(t);
  }
  xml.insert(end, added);
  return xml;
}

RobotModel load_cell_robot(const CellSpec& cell) {
  return RobotModel::from_string(cell_robot_urdf(cell), cell.robot_urdf, cell.robot_package_dirs);
}

}  // namespace weldtwin
