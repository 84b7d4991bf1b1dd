// Replay of a weld plan in the twin: the 200 Hz joint trajectory executed by MuJoCo position servos (with the
// inverse-dynamics feed-forward a real arm controller has), stepped in physics, and watched: tracking error,
// every contact of the robot or torch with the table, clamps, clutter or itself, the torch's clearance to the
// part's exact mesh, and — because the twin knows where the part really is — the TCP's distance to the *true*
// seam at every arc-on sample. That last figure decides whether the weld lands.
#pragma once

#include <string>
#include <vector>

#include "core/part_spec.hpp"
#include "perception/mesh_io.hpp"
#include "planning/weld_planner.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {

struct ReplaySetting {
  /// Physics step: two per 200 Hz sample. Joint tracking at most 5e-4 rad, arc-on TCP tracking 4 um on the
  /// default cell (1 ms: 2e-4 rad and 1.6 um at 2.4x the time; 5 ms: 9e-4 rad — integration error — and
  /// 5.5 um, seam errors within 2 um of these, at half the time).
  double timestep_s = 0.0025;
  double bandwidth_hz = 12.0;      ///< servo bandwidth (PD gains from each joint's inertia at the start)
  double damping_ratio = 1.0;      ///< of the servo loops
  double max_seam_error_m = 1e-3;  ///< every arc-on TCP must be this close to the true seam
  double min_clearance_m =
      0.00025;  ///< robot surfaces closer to the part than this touch it (inside: < 0): fail
  double clearance_range_m = 0.05;  ///< clearances beyond this are not resolved (reported as this)
  double max_tracking_m = 5e-4;     ///< arc-on TCP tracking error allowed
  int threads = 0;                  ///< clearance checks side by side (0: up to 4 cores)
};

/// A pair of geoms in contact (penetration or touch), first seen at t_s.
struct ReplayContact {
  std::string robot_geom, other_geom;
  Label other = Label::kOther;
  double first_t_s = 0.0, last_t_s = 0.0;
  double max_depth_m = 0.0;
  int steps = 0;  ///< physics steps the pair was in contact
};

struct ReplaySample {
  double t_s = 0.0;
  JointVector q_ref = JointVector::Zero(), q = JointVector::Zero();  ///< planned and executed [rad]
  Vec3 tcp_ref = Vec3::Zero(), tcp = Vec3::Zero();                   ///< planned and executed TCP, base
  int seam = -1;
  bool arc = false;
  double seam_error_m = -1.0;  ///< arc-on: executed TCP to the nearest true seam; -1 otherwise
  double clearance_m = 0.0;    ///< nearest robot surface to the part's mesh (negative: inside)
  std::string clearance_geom;  ///< the robot geom that is nearest
};

struct SeamFigure {
  std::string name;
  int samples = 0;  ///< arc-on samples
  double max_error_m = 0.0, rms_error_m = 0.0;
};

struct ReplayResult {
  std::vector<ReplaySample> samples;  ///< one per plan sample
  std::vector<ReplayContact> contacts;
  std::vector<SeamFigure> seams;
  double max_tracking_rad = 0.0;    ///< largest joint error over the whole run
  double max_tcp_tracking_m = 0.0;  ///< largest arc-on TCP error (executed against planned)
  double max_seam_error_m = 0.0;    ///< largest arc-on distance to the true seam
  double min_clearance_m = 0.0;     ///< robot to the part, over the whole run
  std::string min_clearance_geom;
  double min_clearance_t_s = 0.0;
  double wall_s = 0.0;
  std::vector<std::string> failures;  ///< why the replay failed; empty: passed
  bool passed() const { return failures.empty(); }
};

/// Replays `plan` in `world` (whose part stands at the true pose `T_base_part_true`; `part` and
/// `part_mesh` are that part's spec and mesh in metres). Throws only for an empty plan.
ReplayResult replay_plan(const MujocoWorld& world, const RobotModel& robot, const WeldPlan& plan,
                         const PartSpec& part, const Mesh& part_mesh, const Iso3& T_base_part_true,
                         const ReplaySetting& setting = {});

/// Distance from `p` to the polyline of seam `seam` of `part` placed at `T_base_part` [m].
double distance_to_seam(const PartSpec& part, int seam, const Iso3& T_base_part, const Vec3& p);

}  // namespace weldtwin
