// The robot as a kinematic tree loaded from URDF (urdfdom): forward kinematics for any link, joint limits,
// and the link geometry that the MuJoCo cell mirrors.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

using JointVector = Eigen::Matrix<double, 6, 1>;

/// One primitive of a link's collision or visual geometry, in the link frame.
struct LinkGeometry {
  enum class Type { kBox, kCylinder, kSphere };
  Type type = Type::kBox;
  Iso3 T_link_geom = Iso3::Identity();
  Vec3 size =
      Vec3::Zero();  ///< box: full extents [m]; cylinder: (radius, length, 0) [m]; sphere: (radius, 0, 0)
  Eigen::Vector4d rgba{0.7, 0.7, 0.7, 1.0};
};

/// A mesh's file as a URDF names it (`package://NAME/...`, `file://...` or a path relative to the URDF at
/// `source`), resolved as RobotModel::load resolves it; throws InputError naming `source` and `link` when
/// the package or the file is not there.
std::string mesh_file(const std::string& filename, const std::string& source, const std::string& link,
                      const std::vector<std::string>& package_dirs = {});

/// A mesh of a link (the vendor's descriptions give meshes where ours give primitives), in the link frame.
struct LinkMesh {
  std::string path;  ///< the file, resolved: `package://NAME/...` through the folder of package NAME
  Vec3 scale = Vec3::Ones();
  Iso3 T_link_mesh = Iso3::Identity();
};

struct LinkInertial {
  Iso3 T_link_com = Iso3::Identity();
  double mass_kg = 0.0;
  Mat3 inertia = Mat3::Zero();  ///< about the centre of mass, in the inertial frame [kg m^2]
};

struct RobotLink {
  std::string name;
  int parent = -1;                         ///< index into RobotModel::links(), -1 for the root
  std::string joint_name;                  ///< joint from the parent ("" for the root)
  Iso3 T_parent_joint = Iso3::Identity();  ///< joint origin in the parent link frame
  Vec3 axis = Vec3::UnitZ();               ///< joint axis in the child link frame (revolute joints)
  int q_index = -1;                        ///< index of the actuated joint in q, -1 for fixed joints
  double lower_rad = 0.0, upper_rad = 0.0, velocity_rad_s = 0.0;
  std::vector<LinkGeometry> collision;
  std::vector<LinkGeometry> visual;
  std::vector<LinkMesh> collision_meshes, visual_meshes;
  bool has_inertial = false;
  LinkInertial inertial;
};

/// Kinematic tree of a serial robot with revolute and fixed joints. Links are stored parents-first.
class RobotModel {
 public:
  /// Loads a URDF file. Mesh files named `package://NAME/...` are found in the folder of package NAME: a
  /// folder named NAME holding a package.xml, beside or above the URDF's folder, or in one of
  /// `package_dirs` (or of ROS_PACKAGE_PATH's); other relative paths from the URDF's folder. Elements URDF
  /// does not define (a vendor's own) are ignored, each named once in notes(). Throws InputError naming the
  /// file for a malformed file, an unsupported joint, or a mesh that is not there.
  static RobotModel load(const std::string& urdf_path, const std::vector<std::string>& package_dirs = {});
  /// Parses URDF text; `source` names it in error messages (and its folder is where relative paths start).
  static RobotModel from_string(const std::string& urdf_xml, const std::string& source,
                                const std::vector<std::string>& package_dirs = {});

  const std::vector<RobotLink>& links() const { return links_; }
  const std::string& name() const { return name_; }
  int dof() const { return static_cast<int>(joint_names_.size()); }
  const std::vector<std::string>& joint_names() const { return joint_names_; }
  /// What loading left aside, for the user to read ("ignored <dh_type>: not a URDF element").
  const std::vector<std::string>& notes() const { return notes_; }

  /// Index of a link by name, or -1.
  int link_index(const std::string& link_name) const;
  /// Index of a link by name; throws std::out_of_range for an unknown name.
  int require_link(const std::string& link_name) const;

  /// T_base_link for every link (base = the root link), for joint angles q [rad].
  void forward_kinematics(const JointVector& q, std::vector<Iso3>& T_base_link) const;
  /// T_base_link for one link.
  Iso3 forward_kinematics(const JointVector& q, int link) const;

  /// What forward_kinematics(q, link, cache) keeps between calls: the chain from the root to the link and
  /// the products from each of its links to the end. One per link asked and per thread.
  struct ChainCache {
    int link = -1;
    std::vector<int> chain;  ///< link indices, root first
    JointVector q = JointVector::Constant(std::numeric_limits<double>::quiet_NaN());
    std::vector<Mat3> R;  ///< rotation of the product from chain link k to the end
    std::vector<Vec3> p;  ///< its translation
  };
  /// T_base_link for one link asked very often (the sweep poses the LiDAR at every sample and the arm's
  /// bodies at every turn): when only the first joints changed since the last call (a base-joint pass),
  /// only their part of the product is recomputed. Equal to forward_kinematics(q, link) to rounding (the
  /// products are associated the other way).
  Iso3 forward_kinematics(const JointVector& q, int link, ChainCache& cache) const;

  /// Joint limits in q order [rad], [rad/s], [rad/s^2].
  JointVector lower() const { return lower_; }
  JointVector upper() const { return upper_; }
  JointVector max_velocity() const { return max_velocity_; }
  JointVector max_acceleration() const { return max_acceleration_; }
  bool within_limits(const JointVector& q) const;

  /// A copy whose link `link_name` is mounted on its parent by `T_parent_joint * delta` instead: a mount
  /// error (a LiDAR bracket off by a little), or a calibrated mount. Throws std::out_of_range for an unknown
  /// link.
  RobotModel with_mount_offset(const std::string& link_name, const Iso3& delta) const;

 private:
  std::string name_;
  std::vector<RobotLink> links_;
  std::vector<std::string> joint_names_;
  std::vector<std::string> notes_;
  JointVector lower_, upper_, max_velocity_, max_acceleration_;
};

}  // namespace weldtwin
