// The weld program: every seam of a part, at its pose, as torch poses timed by LSPB and the 200 Hz joint
// trajectory of the Aubo i5 that realises them: transit (joint space) -> approach along the torch axis (arc
// off) -> the seam (arc on) -> corner transitions where seams meet -> departure -> ... -> home. Free torch
// rolls are chosen for the largest joint-limit and singularity margin; circular seams that J6 cannot follow
// in one go are split with a re-grip; with a collision test from the cell, branches and rolls that would
// hit the table, clamps or clutter are not chosen and transits are lifted over obstacles. Every sample is
// checked against the joint limits after IK; what cannot be welded is reported by seam name with the reason,
// never slowed down or dropped silently.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/part_spec.hpp"
#include "core/robot_model.hpp"

namespace weldtwin {

struct PlanSetting {
  double blend_fraction = 0.025;       ///< LSPB blend time as a fraction of each seam's time
  double sample_hz = 200.0;            ///< joint stream rate of the controller
  double approach_m = 0.04;            ///< approach and departure distance along the torch axis
  double approach_speed_m_s = 0.02;    ///< approach and departure speed
  double approach_accel_m_s2 = 0.1;    ///< and acceleration
  double limit_fraction = 0.5;         ///< transits and corners use this fraction of the joint limits
  double roll_step_rad = deg2rad(30);  ///< candidate free rolls are tried at this spacing
  double corner_tolerance_m = 1e-3;    ///< seams closer than this at end/start are welded through the corner
  /// Turn the torch on the spot where seams meet, arc on. Off by default: at a sharp outside corner (a square
  /// tube on its plate) the nozzle sweeps into the walls while it turns (the replay's clearance shows it).
  bool weld_through_corners = false;
  double min_margin_rad = deg2rad(3);  ///< joint-limit margin a free-roll choice must keep
  double min_singularity_sine = 0.08;  ///< how far (IkSolution margins) a choice must stay from singularities
  JointVector home = (JointVector() << 0, 0, kPi / 2, 0, kPi / 2, 0).finished();  ///< start and end [rad]
  /// Where the arm stands when the plan begins, if not at home (a real arm after its sweep): the plan's
  /// first transit starts there, so the replay (and the gate) covers the way from there too.
  std::optional<JointVector> start;
  /// What the arm at q collides with ("" when free; `welding`: the arc is on, the torch is meant to be close
  /// to the part), from whoever knows the cell (the twin's CollisionChecker). When set, IK branches and torch
  /// rolls whose stations, approaches or departures collide are not chosen, and a transit that would collide
  /// is lifted instead. Unset: no collision checks.
  std::function<std::string(const JointVector& q, bool welding)> collision;
  double transit_lift_m = 0.15;  ///< how far a lifted transit backs off along the torch axis at both ends
  /// Configurations are asked of `collision` at most this far apart (the largest joint change) along a weld
  /// between its stations and along paths found in joint space (transits: `transit_check_rad`): a round
  /// seam's stations are 12 mm apart on the part while the torch swings tens of millimetres round it between
  /// them.
  double collision_step_rad = 0.02;
  /// Samples of the transits (and of a lifted transit's lines) are asked of `collision` no more than this far
  /// apart (the largest joint change; where the arm turns faster, every 200 Hz sample): two links that graze
  /// for a single sample of a fast transit are seen, and the slow ends of the moves are not asked sample by
  /// sample.
  double transit_check_rad = 0.01;
  /// When a seam cannot be welded as its spec says, try the other ways it allows: the edges of its work and
  /// travel angle windows, and (a free roll) the other direction; a way whose transit, approach or departure
  /// is blocked is taken back and the seam tried from its other end, and then the seams still to weld are
  /// tried before it. Off: the spec's angles, direction and order only.
  bool search_weld_window = true;
  /// Only ask whether every seam has a way (within the same search) whose stations, approach and departure
  /// poses the arm reaches clear of the cell: no transits, no timing, no samples beyond the first. A quick
  /// necessary condition for a plan, for maps of where a part can be welded; `plan_welds` says which seams
  /// fail and why, as always.
  bool stations_only = false;
};

enum class Phase { kTransit, kApproach, kWeld, kCorner, kDeparture };

struct PlanSample {
  double t_s = 0.0;
  JointVector q = JointVector::Zero();
  Iso3 T_base_tcp = Iso3::Identity();
  int seam = -1;     ///< seam index for arc-on samples, -1 otherwise
  bool arc = false;  ///< welding
  Phase phase = Phase::kTransit;
};

struct PlannedSeam {
  std::string name;
  Vec3 start_base = Vec3::Zero(), end_base = Vec3::Zero();
  double length_m = 0.0, speed_m_s = 0.0, roll_rad = 0.0;
  int pieces = 1;  ///< > 1: split with re-grips
  std::vector<double> roll_per_piece_rad;
  double work_angle_rad = 0.0, travel_angle_rad = 0.0;  ///< the angles chosen (the spec's when they work)
  bool reversed = false;                                ///< welded from the spec's end to its start
};

/// Why a plan failed, beside its human reason (`WeldPlan::problems`).
enum class PlanFailure {
  kNone,
  kOutOfReach,     ///< a seam no way of which the arm reaches within its limits and margins
  kCollides,       ///< a seam the arm reaches only where it collides with the cell
  kBlockedMove,    ///< a seam whose stations are clear, but no transit, approach or departure to them is
  kJointLimits,    ///< the trajectory exceeds a joint's velocity or acceleration limit
  kStartCollides,  ///< the arm where the plan starts (home, or where it stands) collides: no move can start
};
const char* plan_failure_name(PlanFailure failure);

struct WeldPlan {
  Iso3 T_flange_tcp = Iso3::Identity();
  std::vector<PlannedSeam> seams;
  std::vector<PlanSample> samples;
  std::vector<std::string> notes;            ///< e.g. re-grips
  std::vector<std::string> problems;         ///< "seam 'x': reason"; empty when the plan is good
  PlanFailure failure = PlanFailure::kNone;  ///< the kind of the first problem
  double duration_s() const { return samples.empty() ? 0.0 : samples.back().t_s; }
  bool ok() const { return problems.empty(); }
};

/// Plans every seam of `part` at T_base_part. Never throws for an unreachable seam: it is in `problems`.
WeldPlan plan_welds(const PartSpec& part, const Iso3& T_base_part, const RobotModel& robot,
                    const PlanSetting& setting = {});

/// Joint velocity and acceleration of the trajectory by finite differences, checked against the limits;
/// returns one line per violated joint and kind (empty when within limits).
std::vector<std::string> check_joint_limits(const std::vector<PlanSample>& samples, const RobotModel& robot,
                                            double sample_hz);
std::vector<std::string> check_joint_limits(const PlanSample* first, size_t count, const RobotModel& robot,
                                            double sample_hz);

}  // namespace weldtwin
