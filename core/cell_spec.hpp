// A welding cell (scenes/cells/*.yaml): the environment MJCF, the robot, the sweep program, the table, where
// a part may be placed, the part with its pose, its clamps, clutter and LiDAR setting overrides.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"
#include "core/robot_model.hpp"  // LinkGeometry

namespace weldtwin {

/// Top of the welding table in the base frame; the top face is the plane z = top_z_m.
struct TableSpec {
  double x_min_m = -0.12, x_max_m = 0.68;
  double y_min_m = -0.60, y_max_m = 0.60;
  double top_z_m = 0.0;
};

/// Where parts may go: their seams within a ring around the robot base, in front of it (the ring the arm
/// welds in), or anywhere on the table top clear of the robot base (where an operator may clamp a part).
struct PlacementSpec {
  enum class Area { kRing, kTable };
  Area area = Area::kRing;                 ///< kTable: the radii and bearing below are not asked
  double min_radius_m = 0.40;              ///< closest seam point to the base axis
  double max_radius_m = 0.56;              ///< farthest seam point from the base axis
  double max_bearing_rad = deg2rad(75.0);  ///< |atan2(y, x)| of the part origin
  /// No part, clamp or clutter within this radius of the base axis: the base, and the arm's shoulder housing,
  /// which hangs about 0.23 m off the axis just above the table at home and sweeps that circle as the base
  /// joint turns.
  double base_keepout_m = 0.26;
};

/// "ring" / "table"; nullopt for any other name.
std::optional<PlacementSpec::Area> placement_area_from(const std::string& name);
const char* placement_area_name(PlacementSpec::Area area);

struct PartPose {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0, yaw_rad = 0.0;
};

struct ClutterItem {
  enum class Type { kBox, kCylinder };
  Type type = Type::kBox;
  Vec3 size_m = Vec3::Zero();  ///< box: full extents; cylinder: (diameter, diameter, height)
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
};

/// A frame as URDF writes it: xyz, then roll, pitch, yaw about the fixed x, y, z axes.
struct UrdfOrigin {
  Vec3 xyz_m = Vec3::Zero();
  Vec3 rpy_rad = Vec3::Zero();
  Iso3 transform() const {
    return make_transform(xyz_m, rpy_to_matrix(rpy_rad.x(), rpy_rad.y(), rpy_rad.z()));
  }
};

/// One shape of a tooling link, used for collision and drawing alike.
struct ToolingShape {
  LinkGeometry::Type type = LinkGeometry::Type::kBox;
  Vec3 size_m =
      Vec3::Zero();   ///< as LinkGeometry::size: box extents; cylinder (radius, length); sphere radius
  UrdfOrigin origin;  ///< in the link's frame
  Eigen::Vector4d rgba{0.12, 0.12, 0.13, 1.0};
};

/// A fixed link the cell adds to the vendor's robot, URDF-style: the torch, the TCP, the LiDAR and its
/// bracket, each on its parent link at `origin`.
struct ToolingLink {
  std::string link, parent;
  UrdfOrigin origin;
  std::vector<ToolingShape> shapes;
  double mass_kg = 0.0;  ///< spread over the shapes as uniform solids; 0: MuJoCo weighs the shapes as water
};

struct CellSpec {
  std::string source;  ///< the YAML file
  std::string name;
  std::string environment_mjcf;  ///< resolved path: table, floor, lights, cameras
  std::string robot_urdf;        ///< resolved path
  std::vector<std::string>
      robot_package_dirs;            ///< resolved folders where `package://NAME` is also looked for
  std::vector<ToolingLink> tooling;  ///< added to the robot, parents first
  std::string sweep_program;         ///< resolved path
  /// Resolved paths (`rescan:` a file, or a list): the programs swept one after another while the part is
  /// not found (passes from other sides; each starts where the one before it ends), the part sought again
  /// in all sweeps so far after each
  std::vector<std::string> rescan_programs;
  std::string part_spec;  ///< resolved path
  TableSpec table;
  PlacementSpec placement;
  std::optional<PartPose> part_pose;  ///< unset: drawn from the seed
  std::vector<int> clamp_sites;       ///< indices into the part's clamp sites
  std::vector<ClutterItem> clutter;
  std::map<std::string, double> lidar_overrides;  ///< LidarSetting fields by name (numbers; booleans as 0/1)

  /// Loads and validates; throws InputError naming the file and the field.
  static CellSpec load(const std::string& yaml_path);
  /// The robot, with its tooling, of a robot file instead of the cell's own (its tooling included): the same
  /// cell with another torch, say. Throws InputError naming the file.
  void use_robot_file(const std::string& robot_yaml);
};

}  // namespace weldtwin
