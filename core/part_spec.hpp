// A weldable part: its mesh (part frame), its weld seams and where clamps may hold it (scenes/parts/*.yaml).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// One weld seam in the part frame. A line runs start -> end; an arc turns about `axis` through `center`
/// from `start` by `sweep_rad` (counter-clockwise about the axis). docs/design.md fixes the torch angle
/// convention.
struct Seam {
  enum class Kind { kLine, kArc };
  std::string name;
  Kind kind = Kind::kLine;
  Vec3 start = Vec3::Zero(), end = Vec3::Zero();
  Vec3 center = Vec3::Zero(), axis = Vec3::UnitZ();
  double radius_m = 0.0, sweep_rad = 0.0;
  Vec3 normal = Vec3::UnitZ();       ///< n: reference surface normal, into the open side
  Vec3 wall_normal = Vec3::UnitX();  ///< m: other member's normal, into the open side (lines)
  bool wall_normal_radial = false;   ///< arcs: m is the outward radial direction at each point
  double work_angle_rad = 0.0, travel_angle_rad = 0.0;  ///< nominal: what the planner prefers
  double work_angle_tol_rad = 0.0;  ///< the planner may tilt the torch this far either side of work_angle
  /// The travel angles the weld accepts (drag < 0 < push), travel_angle within them; both equal to it when
  /// the spec gives no window.
  double travel_angle_min_rad = 0.0, travel_angle_max_rad = 0.0;
  std::optional<double> torch_roll_rad;  ///< nullopt: free, the planner chooses
  double speed_m_s = 0.0;

  double length_m() const;
  /// Point at arc-length fraction s in [0, 1].
  Vec3 point_at(double s) const;
  /// Unit travel direction at fraction s.
  Vec3 direction_at(double s) const;
  /// m at fraction s.
  Vec3 wall_normal_at(double s) const;
  /// The three above at fraction s, the point computed once.
  struct Frame {
    Vec3 point, direction, wall_normal;
  };
  Frame frame_at(double s) const;
  /// Distance from `q` (part frame) to the seam's nearest point, exactly (a line's segment, an arc's circle
  /// within its sweep, else its nearer end) [m]. The one seam distance of the project.
  double distance_to(const Vec3& q) const;
  /// The same seam welded from its end to its start (the torch roll, relative to the travel direction, kept).
  Seam reversed() const;
};

struct ClampSite {
  Vec3 grip = Vec3::Zero();           ///< pad contact point on a top face, part frame [m]
  Eigen::Vector2d outward{1.0, 0.0};  ///< horizontal unit direction from the part towards the clamp body
};

/// Clamp geometry, shared by the MJCF generator, the layout checks and the
/// clamp sites drawn from a part's outline.
struct ClampDims {
  static constexpr double kBaseStart = 0.06;  ///< base block starts this far out from the pad [m]
  static constexpr double kBaseEnd = 0.14;
  static constexpr double kReach = 0.23;  ///< farthest point (handle tip) from the pad [m]
  static constexpr double kHalfWidth = 0.03;
  static constexpr double kPadRadius = 0.011;  ///< rubber pad on the part
};

struct PartSpec {
  std::string name;
  std::string source;     ///< the YAML file
  std::string mesh_path;  ///< resolved path of the mesh
  double height_m = 0.0;
  std::vector<Eigen::Vector2d> footprint;  ///< outline on the table (part frame), counter-clockwise
  std::vector<ClampSite> clamp_sites;
  std::vector<Seam> seams;
  /// How close the weld must land: every seam point where the part was found, and every arc-on torch position
  /// in the replay, within this of the true seam (`weld_tolerance_mm`, default 1 mm: about half the wire and
  /// a fifth of the fillet leg of the parts here). The localizer accepts a pose when its seam error bound is
  /// within it; the run, the benchmark and the survey judge with it and show it.
  double weld_tolerance_m = kDefaultWeldToleranceM;
  static constexpr double kDefaultWeldToleranceM = 1e-3;

  /// Loads and validates a part spec; throws InputError naming the file and the field.
  static PartSpec load(const std::string& yaml_path);
  /// Radius of the smallest origin-centred circle holding the footprint.
  double footprint_radius_m() const;
  /// Points along every seam, about `spacing_m` apart, ends included (part frame).
  std::vector<Vec3> seam_points(double spacing_m) const;

 private:
  static PartSpec parse(const std::string& yaml_path);
};

}  // namespace weldtwin
