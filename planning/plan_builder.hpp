// The weld program under construction: its samples so far, the IK branch and roll chosen for a stretch of
// seam (its stations, approach and departure reached within the margins and clear of the cell), and the
// pieces a plan is made of (transits, approach and departure lines, welds, corners), each taken back when it
// does not work out. Internal to the planner (planning/weld_planner.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "planning/ik_aubo.hpp"
#include "planning/seam_geometry.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {
namespace planner {

// How well a roll and an IK branch suit a stretch of seam.
struct Choice {
  bool ok = false;
  double roll = 0.0;
  int branch = -1;
  double margin = -1.0;
  JointVector q_start = JointVector::Zero();  ///< at the approach's first pose
  Vec3 in_dir = Vec3::Zero(),
       out_dir = Vec3::Zero();  ///< unit, from the weld's start (end) to the approach (departure) pose
};

// A configuration and whether the arc is on, bit for bit, as a key.
using ConfigKey = std::array<double, 7>;
struct ConfigKeyHash {
  template <size_t N>
  size_t operator()(const std::array<double, N>& k) const {
    uint64_t h = 1469598103934665603ull;  // FNV-1a over the bits
    for (double v : k) {
      uint64_t bits;
      std::memcpy(&bits, &v, sizeof bits);
      h = (h ^ bits) * 1099511628211ull;
    }
    return static_cast<size_t>(h);
  }
};

class Builder {
 public:
  // What a piece of trajectory did: ran (its limits are then checked), failed (a slower try may still work:
  // a line whose samples jumped between IK branches), or was blocked (every route it knows collides; a
  // slower try would meet the same).
  enum class Ran { kOk, kFailed, kBlocked };
  static Ran as_ran(bool ok) { return ok ? Ran::kOk : Ran::kFailed; }
  static Ran as_ran(Ran ran) { return ran; }

  Builder(const RobotModel& robot, const PlanSetting& setting, WeldPlan& plan)
      : robot_(robot),
        ik_(robot, "tcp"),
        tcp_link_(robot.require_link("tcp")),
        set_(setting),
        plan_(plan),
        q_(setting.start.value_or(setting.home)),
        dt_(1.0 / setting.sample_hz) {}

  const AuboIk& ik() const { return ik_; }
  /// T_base_tcp at q (the robot model's forward kinematics).
  Iso3 tcp_pose(const JointVector& q) const { return robot_.forward_kinematics(q, tcp_link_); }
  void set_branch(int branch) { branch_ = branch; }
  const JointVector& q() const { return q_; }

  // Margin of a solution: distance to the joint limits and to the shoulder, elbow and wrist singularities;
  // negative when too close to any of them.
  double margin(const IkSolution& s) const;

  // Best roll and branch for the stretch [s0, s1] of a seam, including its approach pose: of those the arm
  // reaches within the margins (IK alone), the one with the largest margin whose stations, ways in and out
  // and what lies between the stations are clear of the cell, the cell asked best first. A fixed roll is the
  // only candidate; `prefer_branch` wins ties (a corner can then be welded through).
  Choice choose(const SeamGeometry& g, double s0, double s1, std::optional<double> fixed_roll,
                int prefer_branch) const;

  // Every IK solution of `pose`, remembered: the stretches a seam's split tries from one start share their
  // first station and approach pose (the same pose, the same reference), for every roll.
  const std::array<IkSolution, 8>& solve_start(const Iso3& pose, double q6_reference) const;

  // Whether what the arm passes through welding the stretch [s0, s1] on branch `b` at `roll` is clear of the
  // cell: poses of the seam (IK, not joint-space interpolation: round a tube the wrist swings a quarter
  // radian from one 12 mm station to the next, and the arm does not move straight in joint space) at most
  // `collision_step_rad` apart in every joint. `q_near`: a configuration near the stretch's start.
  bool clear_along(const SeamGeometry& g, double s0, double s1, double roll, int b,
                   const JointVector& q_near) const;

  // Where the trajectory stands, to take back a piece that did not work out.
  struct Mark {
    size_t samples = 0, problems = 0;
    JointVector q = JointVector::Zero();
    double t = 0.0;
    int branch = 0;
  };
  Mark mark() const { return {plan_.samples.size(), plan_.problems.size(), q_, t_, branch_}; }
  void rewind(const Mark& m);

  // Whether any of the configurations (each with whether the arc is on) collides with the cell (never,
  // without a collision test). What was hit is counted for the message of an unreachable seam.
  bool collides(const std::vector<std::pair<JointVector, bool>>& qs) const;

  // The cell's answer for q, asked once per configuration: the stretches a seam's split tries share their
  // first stations and approach poses exactly (the same pose, the same IK), so the answer is remembered.
  std::string collision(const JointVector& q, bool welding) const;

  // A clear way to (or from) the weld pose `at` on branch `b`: back along the torch axis, or else straight
  // up; the direction and the configuration at its far end, or nothing when both collide or leave the
  // branch. Without a collision test, the torch axis.
  std::optional<std::pair<Vec3, JointVector>> clear_way(const Iso3& at, int b,
                                                        const JointVector& q_near) const;

  // The collision that ruled out the best candidate since the last call, for a message ("" if none did).
  std::string main_collision() const;

  // The collision, if any, of the samples from index `from` on: asked so that no joint turns more than
  // `PlanSetting::transit_check_rad` between two samples asked in a row (where it turns faster, every
  // sample, as the replay watches them), and where the arc goes on or off.
  std::string collision_since(size_t from) const;

  // A transit to `to` (an approach's first pose, or home) that does not hit the cell: straight in joint
  // space if that is free; otherwise out of here along a straight line (straight up, or back along the
  // torch axis), across in joint space (directly, or by way of home, the arm folded up clear of the table),
  // and into `to` along the same kind of line.
  Ran transit(const JointVector& to, const std::string& what);

  // here -> out (line) -> [home] -> in (joint space) -> there (line, ending at `to`). Records no problems.
  bool leg_out_across_in(const Iso3& here, const Iso3& out, bool via_home, const Iso3& in, const Iso3& there,
                         const JointVector& to, const std::string& what);

  bool at_home(const JointVector& q) const { return (q - set_.home).cwiseAbs().maxCoeff() < 1e-9; }

  // The IK branch that puts the TCP at T with the configuration q, or -1.
  int branch_of(const Iso3& T, const JointVector& q) const;

  void problem(const std::string& what) { plan_.problems.push_back(what); }

  // Runs a piece of trajectory; if it fails, or breaks a joint velocity or acceleration limit, the piece is
  // taken back and, unless it is a weld (whose speed is the spec's), tried again at half and a quarter of
  // the speed. Returns false, with the problem recorded, when no try works.
  template <typename Piece>
  bool checked(Piece piece, bool is_weld, const std::string& what);
  // The kind of the last piece that `checked` gave up on: over a joint's velocity or acceleration limit,
  // or blocked (no route, or a pose on it out of reach).
  PlanFailure last_failure() const { return last_failure_; }

  // One sample: the configuration nearest the current one that puts the TCP at `T`.
  bool add(const Iso3& T, int seam, Phase phase, const std::string& what);

  // Joint-space LSPB to `to`, as fast as the scaled limits allow, every joint on the same profile.
  void joint_move(const JointVector& to);

  // Straight TCP line at fixed orientation (approach, departure), arc off.
  bool line(const Iso3& from, const Iso3& to, Phase phase, const std::string& what);

  // The seam itself, arc on: LSPB along its arc length at the weld speed (docs/design.md's timing law).
  bool weld(const SeamGeometry& g, double s0, double s1, double roll, int seam_index);

  // Turning the torch at a corner where two seams meet, the TCP standing still on the corner, arc on.
  bool corner(const Iso3& from, const Iso3& to, int seam_index, const std::string& what);

 private:
  const RobotModel& robot_;
  AuboIk ik_;
  int tcp_link_;
  const PlanSetting& set_;
  WeldPlan& plan_;
  JointVector q_;
  double dt_;
  double t_ = 0.0;
  double slow_ = 1.0;  ///< duration factor of the piece being tried (checked())
  int branch_ = 0;     ///< IK branch of the seam being welded
  mutable std::unordered_map<ConfigKey, std::string, ConfigKeyHash> answers_;  ///< the cell's, by q
  /// IK at stretches' starts (solve_start), by the pose's 12 numbers and the J6 reference.
  mutable std::unordered_map<std::array<double, 13>, std::array<IkSolution, 8>, ConfigKeyHash> start_ik_;
  /// The cell's answer for the welding between two configurations of one seam (clear_along), by both.
  mutable std::unordered_map<std::array<double, 12>, std::string, ConfigKeyHash> along_answers_;
  /// Stations of a stretch at most this far apart on the seam; also clear_along's grid.
  static constexpr double kStationSpacing_m = 0.012;
  mutable std::string last_hit_;      ///< the latest collision found
  mutable std::string rejected_hit_;  ///< what ruled out the best candidate since main_collision()
  mutable double rejected_margin_ = -1.0;
  PlanFailure last_failure_ = PlanFailure::kNone;
};

template <typename Piece>
bool Builder::checked(Piece piece, bool is_weld, const std::string& what) {
  const Mark start = mark();
  const size_t n0 = start.samples, p0 = start.problems;
  std::vector<std::string> why;
  bool over_limits = false;  // `why` says which joint limits the piece broke (else: why it did not run)
  for (double scale : {1.0, 2.0, 4.0}) {
    slow_ = scale;
    const Ran ran = as_ran(piece());
    if (ran == Ran::kOk) {
      const size_t from = n0 >= 2 ? n0 - 2 : 0;
      why = check_joint_limits(plan_.samples.data() + from, plan_.samples.size() - from, robot_,
                               set_.sample_hz);
      over_limits = !why.empty();
      if (why.empty()) {
        slow_ = 1.0;
        return true;
      }
    } else {
      why.assign(plan_.problems.begin() + static_cast<long>(p0), plan_.problems.end());
      over_limits = false;
    }
    rewind(start);
    if (is_weld || ran == Ran::kBlocked) break;
  }
  slow_ = 1.0;
  for (const std::string& w : why)
    problem(is_weld && over_limits ? what + " cannot be welded at its speed: " + w : w);
  if (why.empty()) problem(what + ": failed");
  last_failure_ = over_limits ? PlanFailure::kJointLimits : PlanFailure::kBlockedMove;
  return false;
}

}  // namespace planner
}  // namespace weldtwin
