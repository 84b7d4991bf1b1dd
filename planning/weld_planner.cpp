#include "planning/weld_planner.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "planning/free_path.hpp"
#include "planning/ik_aubo.hpp"
#include "planning/lspb.hpp"
#include "planning/torch_frame.hpp"

namespace weldtwin {
namespace {

// A seam in the base frame, parameterised by arc length s in [0, length].
struct SeamGeometry {
  const Seam* seam = nullptr;
  Iso3 T_base_part = Iso3::Identity();
  double length = 0.0;
  double work = 0.0, travel = 0.0;  ///< the torch's work and travel angles [rad]

  Vec3 point(double s) const { return T_base_part * seam->point_at(s / length); }
  Iso3 tcp(double s, double roll) const {
    const double f = s / length;
    const Mat3& R = T_base_part.linear();
    return make_transform(point(s), torch_orientation(R * seam->direction_at(f), R * seam->normal,
                                                      R * seam->wall_normal_at(f), work, travel, roll));
  }
};

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
  size_t operator()(const ConfigKey& k) const {
    uint64_t h = 1469598103934665603ull;  // FNV-1a over the bits
    for (double v : k) {
      uint64_t bits;
      std::memcpy(&bits, &v, sizeof bits);
      h = (h ^ bits) * 1099511628211ull;
    }
    return static_cast<size_t>(h);
  }
};

Iso3 moved(const Iso3& T, const Vec3& direction, double distance) {
  Iso3 out = T;
  out.translation() += distance * direction;
  return out;
}

Iso3 backed_off(const Iso3& T_tcp, double distance) {
  Iso3 T = T_tcp;
  T.translation() -= distance * T_tcp.linear().col(2);
  return T;
}

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
        set_(setting),
        plan_(plan),
        q_(setting.start.value_or(setting.home)),
        dt_(1.0 / setting.sample_hz) {}

  const AuboIk& ik() const { return ik_; }
  void set_branch(int branch) { branch_ = branch; }
  const JointVector& q() const { return q_; }

  // Margin of a solution: distance to the joint limits and to the shoulder, elbow and wrist singularities;
  // negative when too close to any of them.
  double margin(const IkSolution& s) const {
    const double limits = std::min((s.q - robot_.lower()).minCoeff(), (robot_.upper() - s.q).minCoeff());
    const double singular = std::min({s.shoulder_margin, s.elbow_margin, s.wrist_margin});
    if (limits < set_.min_margin_rad || singular < set_.min_singularity_sine) return -1.0;
    return std::min(limits, singular);
  }

  // Best roll and branch for the stretch [s0, s1] of a seam, including its approach pose. A fixed roll is
  // the only candidate; `prefer_branch` wins ties (a corner can then be welded through).
  Choice choose(const SeamGeometry& g, double s0, double s1, std::optional<double> fixed_roll,
                int prefer_branch, bool any_will_do = false) const {
    std::vector<double> rolls;
    if (fixed_roll) {
      rolls.push_back(*fixed_roll);
    } else {
      for (double r = -kPi; r < kPi - 1e-9; r += set_.roll_step_rad) rolls.push_back(r);
    }
    const int stations = std::max(6, static_cast<int>((s1 - s0) / 0.012));
    Choice best;
    for (double roll : rolls) {
      std::array<double, 8> worst;
      worst.fill(std::numeric_limits<double>::infinity());
      std::array<JointVector, 8> last, first;
      std::array<std::vector<std::pair<double, JointVector>>, 8>
          stations_q;  // (s, q) of each station, for the collision test of a winner
      // Stations along the stretch, plus its approach (k = -1) and departure (k = stations + 1) poses.
      for (int k = -1; k <= stations + 1; ++k) {
        const Iso3 pose = k < 0          ? backed_off(g.tcp(s0, roll), set_.approach_m)
                          : k > stations ? backed_off(g.tcp(s1, roll), set_.approach_m)
                                         : g.tcp(s0 + (s1 - s0) * k / stations, roll);
        const auto sols = ik_.solve(pose, k < 0 ? q_[5] : last[0][5]);
        for (int b = 0; b < 8; ++b) {
          const IkSolution& s = sols[static_cast<size_t>(b)];
          double m = s.valid && s.within_limits ? margin(s) : -1.0;
          if (m >= 0 && k > 0 && k <= stations &&
              (s.q - last[static_cast<size_t>(b)]).cwiseAbs().maxCoeff() > 0.3)
            m = -1.0;
          worst[static_cast<size_t>(b)] = std::min(worst[static_cast<size_t>(b)], m);
          if (s.valid) last[static_cast<size_t>(b)] = s.q;
          if (set_.collision && m >= 0 && k >= 0 && k <= stations)
            stations_q[static_cast<size_t>(b)].emplace_back(s0 + (s1 - s0) * k / stations, s.q);
          if (k < 0) first[static_cast<size_t>(b)] = s.q;
        }
        // Stop on this roll once no branch can still win.
        if (std::all_of(worst.begin(), worst.end(),
                        [&](double m) { return m < 0.0 || m + 0.05 <= best.margin; }))
          break;
      }
      for (int b = 0; b < 8; ++b) {
        const double m = worst[static_cast<size_t>(b)] + (b == prefer_branch ? 0.05 : 0.0);
        if (worst[static_cast<size_t>(b)] < 0 || m <= best.margin) continue;
        const auto rejected = [&] {  // the best candidate a collision ruled out names the problem
          if (m > rejected_margin_) {
            rejected_margin_ = m;
            rejected_hit_ = last_hit_;
          }
        };
        if (collides(between_stations(g, roll, b, stations_q[static_cast<size_t>(b)]))) {
          rejected();
          continue;
        }
        const auto in = clear_way(g.tcp(s0, roll), b, first[static_cast<size_t>(b)]);
        const auto out = in ? clear_way(g.tcp(s1, roll), b, last[static_cast<size_t>(b)]) : std::nullopt;
        if (!in || !out) {
          if (!last_hit_.empty()) rejected();
          continue;
        }
        best = {true, roll, b, m, in->second, in->first, out->first};
      }
      if (any_will_do && best.ok) return best;  // feasibility is all the caller asks
    }
    return best;
  }

  // What the arm passes through welding from station to station (each (s, q)) on branch `b` at `roll`: the
  // stations, and between two whose configurations differ by more than `collision_step_rad` in some joint,
  // poses of the seam between them (IK, not joint-space interpolation: round a tube the wrist swings a
  // quarter radian from one station to the next, and the arm does not move straight in joint space).
  std::vector<std::pair<JointVector, bool>> between_stations(
      const SeamGeometry& g, double roll, int b,
      const std::vector<std::pair<double, JointVector>>& stations) const {
    std::vector<std::pair<JointVector, bool>> out;
    for (size_t k = 0; k < stations.size(); ++k) {
      if (k > 0) {
        const auto& [sa, qa] = stations[k - 1];
        const auto& [sb, qb] = stations[k];
        const double change = (qb - qa).cwiseAbs().maxCoeff();
        const int n = std::min(64, static_cast<int>(std::ceil(change / set_.collision_step_rad - 1e-9)));
        JointVector prev = qa;
        for (int i = 1; i < n; ++i) {
          const IkSolution sol = ik_.solve_branch(g.tcp(sa + (sb - sa) * i / n, roll), b, prev[5]);
          if (!sol.valid) continue;  // the stations on both sides were reached; the check is the point
          out.emplace_back(sol.q, true);
          prev = sol.q;
        }
      }
      out.emplace_back(stations[k].second, true);
    }
    return out;
  }

  // Where the trajectory stands, to take back a piece that did not work out.
  struct Mark {
    size_t samples = 0, problems = 0;
    JointVector q = JointVector::Zero();
    double t = 0.0;
    int branch = 0;
  };
  Mark mark() const { return {plan_.samples.size(), plan_.problems.size(), q_, t_, branch_}; }
  void rewind(const Mark& m) {
    plan_.samples.resize(m.samples);
    plan_.problems.resize(m.problems);
    q_ = m.q;
    t_ = m.t;
    branch_ = m.branch;
  }

  // Whether any of the configurations (each with whether the arc is on) collides with the cell (never,
  // without a collision test). What was hit is counted for the message of an unreachable seam.
  bool collides(const std::vector<std::pair<JointVector, bool>>& qs) const {
    if (!set_.collision) return false;
    for (const auto& [q, welding] : qs) {
      std::string hit = collision(q, welding);
      if (hit.empty()) continue;
      last_hit_ = hit;
      return true;
    }
    return false;
  }

  // The cell's answer for q, asked once per configuration: the stretches a seam's split tries share their
  // first stations and approach poses exactly (the same pose, the same IK), so the answer is remembered.
  std::string collision(const JointVector& q, bool welding) const {
    const ConfigKey key{q[0], q[1], q[2], q[3], q[4], q[5], welding ? 1.0 : 0.0};
    if (const auto it = answers_.find(key); it != answers_.end()) return it->second;
    if (answers_.size() > 200000) answers_.clear();
    std::string hit = set_.collision(q, welding);
    answers_.emplace(key, hit);
    return hit;
  }

  // A clear way to (or from) the weld pose `at` on branch `b`: back along the torch axis, or else straight
  // up; the direction and the configuration at its far end, or nothing when both collide or leave the
  // branch. Without a collision test, the torch axis.
  std::optional<std::pair<Vec3, JointVector>> clear_way(const Iso3& at, int b,
                                                        const JointVector& q_near) const {
    last_hit_.clear();
    for (const Vec3& dir : {Vec3(-at.linear().col(2)), Vec3(Vec3::UnitZ())}) {
      std::vector<std::pair<JointVector, bool>> qs;
      JointVector prev = q_near;
      bool ok = true;
      for (double f : {1.0, 0.75, 0.5, 0.25, 0.1}) {
        const IkSolution sol = ik_.solve_branch(moved(at, dir, f * set_.approach_m), b, prev[5]);
        if (!sol.valid || !sol.within_limits || (f < 1.0 && (sol.q - prev).cwiseAbs().maxCoeff() > 0.3)) {
          ok = false;
          break;
        }
        qs.emplace_back(sol.q, false);
        prev = sol.q;
      }
      if (ok && !collides(qs)) return std::make_pair(dir, qs.front().first);
      if (!set_.collision) break;
    }
    return std::nullopt;
  }

  // The collision that ruled out the best candidate since the last call, for a message ("" if none did).
  std::string main_collision() const {
    std::string what = rejected_hit_;
    rejected_hit_.clear();
    rejected_margin_ = -1.0;
    return what;
  }

  // The collision, if any, of the samples from index `from` on (every other one: 10 ms apart). Every one,
  // as the replay watches them, would catch two links grazing for one sample of a fast transit (1 trial in
  // 900 of the whole-table benchmark) at twice the planning time (median 0.19 -> 0.45 s over 100 trials).
  std::string collision_since(size_t from) const {
    std::string what;
    if (!set_.collision) return what;
    for (size_t k = from; k < plan_.samples.size(); k += 2)
      if (!(what = set_.collision(plan_.samples[k].q, plan_.samples[k].arc)).empty()) break;
    return what;
  }

  // A transit to `to` (an approach's first pose, or home) that does not hit the cell: straight in joint
  // space if that is free; otherwise out of here along a straight line (straight up, or back along the
  // torch axis), across in joint space (directly, or by way of home, the arm folded up clear of the table),
  // and into `to` along the same kind of line.
  Ran transit(const JointVector& to, const std::string& what) {
    const Mark start = mark();
    joint_move(to);
    std::string hit = collision_since(start.samples);
    if (hit.empty()) return Ran::kOk;
    rewind(start);
    const Iso3 here = ik_.fk(q_), there = ik_.fk(to);
    const double top = std::max(here.translation().z(), there.translation().z()) + set_.transit_lift_m;
    auto up = [&](const Iso3& T) {
      Iso3 U = T;
      U.translation().z() = top;
      return U;
    };
    for (const bool via_home : {false, true})
      for (const bool vertical : {true, false}) {
        if (via_home && (at_home(q_) || at_home(to))) continue;
        const Iso3 out = vertical ? up(here) : backed_off(here, set_.transit_lift_m);
        const Iso3 in = vertical ? up(there) : backed_off(there, set_.transit_lift_m);
        const bool legs = leg_out_across_in(here, out, via_home, in, there, to, what);
        if (legs && collision_since(start.samples).empty()) return Ran::kOk;
        rewind(start);
      }
    // Last: a path found in the free joint space, run waypoint to waypoint.
    const std::vector<JointVector> path = free_joint_path(
        q_, to, robot_.lower(), robot_.upper(),
        [&](const JointVector& q) { return set_.collision(q, false).empty(); }, set_.collision_step_rad);
    if (!path.empty()) {
      for (size_t k = 1; k < path.size(); ++k) joint_move(path[k]);
      if ((q_ - to).cwiseAbs().maxCoeff() < 1e-9) return Ran::kOk;
      rewind(start);
    }
    problem(what + ": collides with " + hit + " (straight, lifted, by way of home, or any way found in " +
            "joint space)");
    return Ran::kBlocked;
  }

  // here -> out (line) -> [home] -> in (joint space) -> there (line, ending at `to`). Records no problems.
  bool leg_out_across_in(const Iso3& here, const Iso3& out, bool via_home, const Iso3& in, const Iso3& there,
                         const JointVector& to, const std::string& what) {
    const size_t p0 = plan_.problems.size();
    const int saved = branch_;
    bool ok = (branch_ = branch_of(here, q_)) >= 0 && line(here, out, Phase::kTransit, what);
    if (ok && via_home) joint_move(set_.home);
    if (ok && (branch_ = branch_of(there, to)) >= 0) {
      const IkSolution sol = ik_.solve_branch(in, branch_, to[5]);
      ok = sol.valid && sol.within_limits;
      if (ok) {
        JointVector q_in = sol.q;
        for (int j = 0; j < 6; ++j) q_in[j] = to[j] + std::remainder(q_in[j] - to[j], 2.0 * kPi);
        joint_move(q_in);
        ok = line(in, there, Phase::kTransit, what) && (q_ - to).cwiseAbs().maxCoeff() < 1e-6;
      }
    } else {
      ok = false;
    }
    branch_ = saved;
    plan_.problems.resize(p0);
    return ok;
  }

  bool at_home(const JointVector& q) const { return (q - set_.home).cwiseAbs().maxCoeff() < 1e-9; }

  // The IK branch that puts the TCP at T with the configuration q, or -1.
  int branch_of(const Iso3& T, const JointVector& q) const {
    for (int b = 0; b < 8; ++b) {
      const IkSolution s = ik_.solve_branch(T, b, q[5]);
      if (!s.valid) continue;
      bool same = true;
      for (int j = 0; j < 6; ++j) same &= std::abs(std::remainder(s.q[j] - q[j], 2.0 * kPi)) < 1e-6;
      if (same) return b;
    }
    return -1;
  }

  void problem(const std::string& what) { plan_.problems.push_back(what); }

  // Runs a piece of trajectory; if it fails, or breaks a joint velocity or acceleration limit, the piece is
  // taken back and, unless it is a weld (whose speed is the spec's), tried again at half and a quarter of
  // the speed. Returns false, with the problem recorded, when no try works.
  template <typename Piece>
  bool checked(Piece piece, bool is_weld, const std::string& what) {
    const Mark start = mark();
    const size_t n0 = start.samples, p0 = start.problems;
    std::vector<std::string> why;
    for (double scale : {1.0, 2.0, 4.0}) {
      slow_ = scale;
      const Ran ran = as_ran(piece());
      if (ran == Ran::kOk) {
        const size_t from = n0 >= 2 ? n0 - 2 : 0;
        const std::vector<PlanSample> window(plan_.samples.begin() + static_cast<long>(from),
                                             plan_.samples.end());
        why = check_joint_limits(window, robot_, set_.sample_hz);
        if (why.empty()) {
          slow_ = 1.0;
          return true;
        }
      } else {
        why.assign(plan_.problems.begin() + static_cast<long>(p0), plan_.problems.end());
      }
      rewind(start);
      if (is_weld || ran == Ran::kBlocked) break;
    }
    slow_ = 1.0;
    for (const std::string& w : why)
      problem(is_weld && w.rfind("joint", 0) == 0 ? what + " cannot be welded at its speed: " + w : w);
    if (why.empty()) problem(what + ": failed");
    return false;
  }

  // One sample: the configuration nearest the current one that puts the TCP at `T`.
  bool add(const Iso3& T, int seam, Phase phase, const std::string& what) {
    const bool arc = phase == Phase::kWeld || phase == Phase::kCorner;
    // The IK branch chosen for the seam; no hopping to a neighbouring branch near a singularity.
    const IkSolution sol = ik_.solve_branch(T, branch_, q_[5]);
    if (!sol.valid || !sol.within_limits) {
      problem(what + ": a pose on the path is out of reach");
      return false;
    }
    JointVector next = sol.q;
    // Angles are in (-pi, pi]: take the turn nearest to the current configuration.
    for (int j = 0; j < 6; ++j) next[j] = q_[j] + std::remainder(next[j] - q_[j], 2.0 * kPi);
    if (((next - robot_.lower()).array() < 0).any() || ((robot_.upper() - next).array() < 0).any()) {
      problem(what + ": a pose on the path is out of reach");
      return false;
    }
    // Between two samples no joint can move more than its velocity limit allows, with some slack: a bigger
    // step is a jump to another IK branch.
    if (((next - q_).cwiseAbs().array() > 1.5 * robot_.max_velocity().array() * dt_).any()) {
      problem(what + ": the path needs a configuration change (IK branch flip)");
      return false;
    }
    q_ = next;
    t_ += dt_;
    plan_.samples.push_back({t_, q_, T, seam, arc, phase});
    return true;
  }

  // Joint-space LSPB to `to`, as fast as the scaled limits allow, every joint on the same profile.
  void joint_move(const JointVector& to) {
    const JointVector from = q_, delta = to - from;
    double duration = 0.0;
    Lspb law;
    for (int j = 0; j < 6; ++j) {
      const Lspb l = Lspb::fastest(std::abs(delta[j]), set_.limit_fraction * robot_.max_velocity()[j] / slow_,
                                   set_.limit_fraction * robot_.max_acceleration()[j] / (slow_ * slow_));
      if (l.duration > duration) {
        duration = l.duration;
        law = l;
      }
    }
    const int n = static_cast<int>(std::ceil(duration / dt_ - 1e-9));
    for (int k = 1; k <= n; ++k) {
      double s, sd, sdd;
      law.at(k * dt_, s, sd, sdd);
      q_ = from + (law.length > 0 ? s / law.length : 1.0) * delta;
      t_ += dt_;
      plan_.samples.push_back({t_, q_, ik_.fk(q_), -1, false, Phase::kTransit});
    }
  }

  // Straight TCP line at fixed orientation (approach, departure), arc off.
  bool line(const Iso3& from, const Iso3& to, Phase phase, const std::string& what) {
    const Vec3 delta = to.translation() - from.translation();
    const Lspb law = Lspb::fastest(delta.norm(), set_.approach_speed_m_s / slow_,
                                   set_.approach_accel_m_s2 / (slow_ * slow_));
    const int n = static_cast<int>(std::ceil(law.duration / dt_ - 1e-9));
    for (int k = 1; k <= n; ++k) {
      double s, sd, sdd;
      law.at(k * dt_, s, sd, sdd);
      Iso3 T = from;
      T.translation() += (law.length > 0 ? s / law.length : 1.0) * delta;
      if (!add(T, -1, phase, what)) return false;
    }
    return true;
  }

  // The seam itself, arc on: LSPB along its arc length at the weld speed (docs/design.md's timing law).
  bool weld(const SeamGeometry& g, double s0, double s1, double roll, int seam_index) {
    const Lspb law = Lspb::with_blend_fraction(s1 - s0, g.seam->speed_m_s, set_.blend_fraction);
    const int n = static_cast<int>(std::ceil(law.duration / dt_ - 1e-9));
    for (int k = 1; k <= n; ++k) {
      double s, sd, sdd;
      law.at(k * dt_, s, sd, sdd);
      if (!add(g.tcp(s0 + s, roll), seam_index, Phase::kWeld, "seam '" + g.seam->name + "'")) return false;
    }
    return true;
  }

  // Turning the torch at a corner where two seams meet, the TCP standing still on the corner, arc on.
  bool corner(const Iso3& from, const Iso3& to, int seam_index, const std::string& what) {
    JointVector q_to;
    if (!ik_.nearest(to, q_, q_to)) {
      problem(what + ": the corner's end pose is out of reach");
      return false;
    }
    double duration = 0.0;
    for (int j = 0; j < 6; ++j)
      duration = std::max(
          duration, Lspb::fastest(std::abs(q_to[j] - q_[j]), set_.limit_fraction * robot_.max_velocity()[j],
                                  set_.limit_fraction * robot_.max_acceleration()[j])
                        .duration);
    duration = std::max(duration, 0.2) * slow_;
    const Lspb law = Lspb::fastest(1.0, 1.0 / (0.5 * duration), 1.0 / (0.25 * duration * duration));
    const Quat a(from.linear()), b(to.linear());
    const int n = static_cast<int>(std::ceil(law.duration / dt_ - 1e-9));
    for (int k = 1; k <= n; ++k) {
      double s, sd, sdd;
      law.at(k * dt_, s, sd, sdd);
      if (!add(make_transform(from.translation(), a.slerp(s, b).toRotationMatrix()), seam_index,
               Phase::kCorner, what))
        return false;
    }
    return true;
  }

 private:
  const RobotModel& robot_;
  AuboIk ik_;
  const PlanSetting& set_;
  WeldPlan& plan_;
  JointVector q_;
  double dt_;
  double t_ = 0.0;
  double slow_ = 1.0;  ///< duration factor of the piece being tried (checked())
  int branch_ = 0;     ///< IK branch of the seam being welded
  mutable std::unordered_map<ConfigKey, std::string, ConfigKeyHash> answers_;  ///< the cell's, by q
  mutable std::string last_hit_;                                               ///< the latest collision found
  mutable std::string rejected_hit_;  ///< what ruled out the best candidate since main_collision()
  mutable double rejected_margin_ = -1.0;
};

// How welding one seam from where the plan stands went.
struct SeamAttempt {
  bool ok = false;
  std::string refusal;  ///< why no way of it works ("" when one does)
  PlanFailure kind = PlanFailure::kNone;
  bool moves_failed = false;  ///< some way of it was blocked on its moves (elsewhere it may not be)
};

}  // namespace

const char* plan_failure_name(PlanFailure failure) {
  switch (failure) {
    case PlanFailure::kNone:
      return "none";
    case PlanFailure::kOutOfReach:
      return "out_of_reach";
    case PlanFailure::kCollides:
      return "collides";
    case PlanFailure::kBlockedMove:
      return "blocked_move";
    case PlanFailure::kJointLimits:
      return "joint_limits";
    case PlanFailure::kStartCollides:
      return "start_collides";
  }
  return "?";
}

const char* phase_name(Phase phase) {
  switch (phase) {
    case Phase::kTransit:
      return "transit";
    case Phase::kApproach:
      return "approach";
    case Phase::kWeld:
      return "weld";
    case Phase::kCorner:
      return "corner";
    case Phase::kDeparture:
      return "departure";
  }
  return "?";
}

WeldPlan plan_welds(const PartSpec& part, const Iso3& T_base_part, const RobotModel& robot,
                    const PlanSetting& setting) {
  WeldPlan plan;
  const JointVector zero = JointVector::Zero();
  plan.T_flange_tcp = robot.forward_kinematics(zero, robot.require_link("flange")).inverse() *
                      robot.forward_kinematics(zero, robot.require_link("tcp"));
  Builder b(robot, setting, plan);
  plan.samples.reserve(32768);
  const JointVector first = setting.start.value_or(setting.home);
  plan.samples.push_back({0.0, first, b.ik().fk(first), -1, false, Phase::kTransit});
  if (setting.collision) {
    if (const std::string hit = setting.collision(first, false); !hit.empty()) {
      plan.problems.push_back("the arm where the plan starts collides (" + hit +
                              "): clear it away; no move can start from there");
      plan.failure = PlanFailure::kStartCollides;
      return plan;
    }
  }

  bool at_corner = false;  // the TCP stands at the start of the next seam with the arc on
  int branch = -1;
  // Welds seam i from where the plan stands, the first of its ways that works; when none does, the plan is
  // as it was before and the refusal says why.
  auto weld_seam = [&](size_t i) -> SeamAttempt {
    const Seam& spec_seam = part.seams[i];
    const std::string what = "seam '" + spec_seam.name + "'";
    // Split a way of welding the seam into pieces that one roll and one IK branch can weld (more than one:
    // re-grips). Greedy longest stretches give the number of pieces; equal pieces are preferred, so no piece
    // is too short to blend. Returns why it cannot be welded so ("" when it can).
    std::vector<std::pair<double, double>> pieces;
    std::vector<Choice> choices;
    bool split_collided = false;  // the last split that failed: where the arm reached, it collided
    auto split = [&](const SeamGeometry& g) -> std::string {
      const Seam& seam = *g.seam;
      pieces.clear();
      choices.clear();
      double s0 = 0.0;
      while (s0 < g.length - 1e-9) {
        // Only feasibility is asked (stations only): the first roll and branch that works will do.
        Choice c = b.choose(g, s0, g.length, seam.torch_roll_rad, branch, setting.stations_only);
        double s1 = g.length;
        if (!c.ok && seam.kind == Seam::Kind::kArc && !seam.torch_roll_rad) {
          // The longest stretch from s0 that some roll can weld, by bisection on its end.
          double lo = s0, hi = g.length;
          for (int it = 0; it < 7; ++it) {
            const double mid = 0.5 * (lo + hi);
            if (b.choose(g, s0, mid, seam.torch_roll_rad, branch, true).ok) {
              lo = mid;
            } else {
              hi = mid;
            }
          }
          s1 = lo;
          c = b.choose(g, s0, s1, seam.torch_roll_rad, branch, setting.stations_only);
          // Leave no stub too short to blend at the weld speed: end this piece earlier instead.
          constexpr double kMinPiece = 0.025;
          if (g.length - s1 < kMinPiece && g.length - kMinPiece - s0 >= 0.01) {
            s1 = g.length - kMinPiece;
            c = b.choose(g, s0, s1, seam.torch_roll_rad, branch, setting.stations_only);
          }
          if (s1 - s0 < 0.01) c.ok = false;
        }
        if (!c.ok) {
          const std::string hit = b.main_collision();
          split_collided = !hit.empty();
          return std::string(seam.torch_roll_rad ? "unreachable with its torch roll"
                                                 : "unreachable with any torch roll") +
                 (hit.empty() ? " (out of reach, or closer than the set margins to the joint limits or to a"
                                " singularity)"
                              : " (where the arm reaches it, it collides: " + hit + ")");
        }
        pieces.emplace_back(s0, s1);
        choices.push_back(c);
        s0 = s1;
      }
      for (size_t n = pieces.size(); !setting.stations_only && n > 1 && n <= pieces.size() + 1; ++n) {
        std::vector<std::pair<double, double>> equal;
        std::vector<Choice> equal_choices;
        for (size_t k = 0; k < n; ++k) {
          const double a = g.length * static_cast<double>(k) / static_cast<double>(n);
          const double e = g.length * static_cast<double>(k + 1) / static_cast<double>(n);
          if (!b.choose(g, a, e, seam.torch_roll_rad, branch, true).ok) break;
          const Choice c = b.choose(g, a, e, seam.torch_roll_rad, branch);
          equal.emplace_back(a, e);
          equal_choices.push_back(c);
        }
        if (equal.size() == n) {
          pieces = equal;
          choices = equal_choices;
          break;
        }
      }
      return std::string();
    };

    // The ways to weld it, nearest the spec first: its nominal angles, then the edges of its work and travel
    // windows; each in the spec's direction, then (a free roll, no welding through corners) reversed.
    struct Way {
      Seam seam;
      double work = 0.0, travel = 0.0, cost = 0.0;
      bool reversed = false;
    };
    std::vector<Way> ways;
    {
      std::vector<double> works{spec_seam.work_angle_rad}, travels{spec_seam.travel_angle_rad};
      if (spec_seam.work_angle_tol_rad > 0)
        works.insert(works.end(), {spec_seam.work_angle_rad - spec_seam.work_angle_tol_rad,
                                   spec_seam.work_angle_rad + spec_seam.work_angle_tol_rad});
      for (double t : {spec_seam.travel_angle_min_rad, spec_seam.travel_angle_max_rad})
        if (std::abs(t - spec_seam.travel_angle_rad) > 1e-9) travels.push_back(t);
      const bool may_reverse = !spec_seam.torch_roll_rad && !setting.weld_through_corners;
      if (!setting.search_weld_window) works.resize(1), travels.resize(1);
      for (double w : works)
        for (double t : travels)
          for (bool rev : {false, true})
            if (!rev || (may_reverse && setting.search_weld_window))
              ways.push_back({rev ? spec_seam.reversed() : spec_seam, w, t,
                              std::hypot(w - spec_seam.work_angle_rad, t - spec_seam.travel_angle_rad) +
                                  (rev ? 1e-6 : 0.0),
                              rev});
      std::stable_sort(ways.begin(), ways.end(), [](const Way& x, const Way& y) { return x.cost < y.cost; });
    }

    // Runs the pieces of a way that split: to each piece (through the corner from the previous seam, or
    // departing from it, a transit and an approach), its weld and its departure. False, with the problem
    // recorded, when a move on the way is blocked.
    auto weld_pieces = [&](const SeamGeometry& g) {
      for (size_t k = 0; k < pieces.size(); ++k) {
        const Choice& c = choices[k];
        const Iso3 start = g.tcp(pieces[k].first, c.roll);
        const size_t problems_before = plan.problems.size();
        bool through_corner = false;
        if (at_corner && k == 0 && c.branch == branch) {
          // Weld through the corner: turn the torch on the spot from the previous seam's end. If the turn
          // cannot be made within the limits, stop and start again instead.
          const Iso3 here = plan.samples.back().T_base_tcp;
          through_corner = b.checked(
              [&] { return b.corner(here, start, static_cast<int>(i), what + " (corner)"); }, false, what);
          if (!through_corner) plan.problems.resize(problems_before);
        }
        if (!through_corner) {
          if (at_corner) {
            const Iso3 here = plan.samples.back().T_base_tcp;
            if (!b.checked(
                    [&] {
                      return b.line(here, backed_off(here, setting.approach_m), Phase::kDeparture,
                                    "departure before " + what);
                    },
                    false, "departure before " + what))
              return false;
          }
          b.set_branch(c.branch);
          if (!b.checked([&] { return b.transit(c.q_start, "transit to " + what); }, false,
                         "transit to " + what))
            return false;
          if (!b.checked(
                  [&] {
                    return b.line(moved(start, c.in_dir, setting.approach_m), start, Phase::kApproach,
                                  "approach to " + what);
                  },
                  false, "approach to " + what))
            return false;
        }
        branch = c.branch;
        if (!b.checked(
                [&] { return b.weld(g, pieces[k].first, pieces[k].second, c.roll, static_cast<int>(i)); },
                true, what))
          return false;
        at_corner = true;
        const bool next_joins =
            setting.weld_through_corners && i + 1 < part.seams.size() && k + 1 == pieces.size() &&
            (g.point(g.length) - T_base_part * part.seams[i + 1].start).norm() < setting.corner_tolerance_m;
        if (!next_joins) {
          const Iso3 here = plan.samples.back().T_base_tcp;
          if (!b.checked(
                  [&] {
                    return b.line(here, moved(here, c.out_dir, setting.approach_m), Phase::kDeparture,
                                  "departure from " + what);
                  },
                  false, "departure from " + what))
            return false;
          at_corner = false;
        }
      }
      return true;
    };

    // The first way that splits and whose moves are clear wins. A way whose moves fail (a transit blocked by
    // a clamp, say) is taken back and the seam tried from its other end: the other angles of the same
    // direction would move to within a centimetre or two of the same poses. What ruled out the spec's way
    // is said in a note (or the refusal).
    const Builder::Mark before = b.mark();
    const bool at_corner_before = at_corner;
    const int branch_before = branch;
    const size_t notes_before = plan.notes.size();
    std::string nominal_problem;        // what ruled out the first way
    bool nominal_split_failed = false;  // ... when splitting it (else on a move, which the problem names)
    PlanFailure nominal_kind = PlanFailure::kNone;
    bool welded = false;
    bool moves_failed[2] = {false, false};  // per direction: forward, reversed
    int tried = 0;
    bool tried_angles = false, tried_reversed = false;
    for (const Way& way : ways) {
      if (moves_failed[way.reversed]) continue;
      ++tried;
      tried_angles |= way.cost > 1e-3;
      tried_reversed |= way.reversed;
      const SeamGeometry g{&way.seam, T_base_part, way.seam.length_m(), way.work, way.travel};
      std::string problem = split(g);
      const bool split_failed = !problem.empty();
      if (!split_failed) {
        if (&way != &ways.front()) {
          std::ostringstream note;
          note << what << ": welded";
          if (way.reversed) note << " from its end to its start";
          if (way.cost > 1e-3)
            note << (way.reversed ? "," : "") << " at work " << std::lround(rad2deg(way.work))
                 << " deg, travel " << std::lround(rad2deg(way.travel)) << " deg";
          note << " (as specified: " << nominal_problem << ")";
          plan.notes.push_back(note.str());
        }
        if (pieces.size() > 1) {
          std::ostringstream note;
          note << what << ": J6 cannot follow it in one go; welded in " << pieces.size()
               << " pieces with re-grips at";
          for (size_t k = 1; k < pieces.size(); ++k) note << ' ' << 1000.0 * pieces[k].first << " mm";
          plan.notes.push_back(note.str());
        }
        if (setting.stations_only || weld_pieces(g)) {
          PlannedSeam ps;
          ps.name = way.seam.name;
          ps.start_base = g.point(0.0);
          ps.end_base = g.point(g.length);
          ps.length_m = g.length;
          ps.speed_m_s = way.seam.speed_m_s;
          ps.work_angle_rad = way.work;
          ps.travel_angle_rad = way.travel;
          ps.reversed = way.reversed;
          ps.pieces = static_cast<int>(pieces.size());
          ps.roll_rad = choices.front().roll;
          for (const Choice& c : choices) ps.roll_per_piece_rad.push_back(c.roll);
          plan.seams.push_back(ps);
          welded = true;
          break;
        }
        problem = plan.problems.front();
        moves_failed[way.reversed] = true;
        b.rewind(before);
        plan.notes.resize(notes_before);
        at_corner = at_corner_before;
        branch = branch_before;
      }
      if (nominal_problem.empty()) {
        nominal_problem = problem;
        nominal_split_failed = split_failed;
        nominal_kind = !split_failed    ? PlanFailure::kBlockedMove
                       : split_collided ? PlanFailure::kCollides
                                        : PlanFailure::kOutOfReach;
      }
    }
    if (!welded) {
      std::string also;
      if (tried > 1) {
        also = "; tried " + std::to_string(tried) + " ways (" +
               (tried_angles ? "work and travel angles within its window" : "") +
               (tried_angles && tried_reversed ? ", " : "") + (tried_reversed ? "both directions" : "") + ")";
      }
      return {false, (nominal_split_failed ? what + ": " : std::string()) + nominal_problem + also,
              nominal_kind, moves_failed[0] || moves_failed[1]};
    }
    return {true, "", PlanFailure::kNone, false};
  };

  // The seams in the spec's order. When one's moves are blocked from where the previous one ended, the
  // seams still to weld are tried in its place, and it is tried again after them, from elsewhere (not when
  // corners are welded through: that needs the spec's order).
  std::vector<size_t> left(part.seams.size());
  for (size_t k = 0; k < left.size(); ++k) left[k] = k;
  const bool may_reorder = setting.search_weld_window && !setting.weld_through_corners;
  while (!left.empty()) {
    std::optional<SeamAttempt> refused;  // the next seam in the spec's order
    size_t chosen = left.size();
    for (size_t k = 0; k < left.size(); ++k) {
      SeamAttempt a = weld_seam(left[k]);
      if (a.ok) {
        chosen = k;
        break;
      }
      if (!refused) refused = a;
      if (!refused->moves_failed || !may_reorder) break;
    }
    if (chosen == left.size()) {
      plan.problems.push_back(refused->refusal);
      plan.failure = refused->kind;
      break;
    }
    if (chosen > 0)
      plan.notes.push_back("seam '" + part.seams[left[chosen]].name + "': welded before seam '" +
                           part.seams[left[0]].name + "' (from where the plan stood: " + refused->refusal +
                           ")");
    left.erase(left.begin() + static_cast<long>(chosen));
  }
  if (setting.stations_only) return plan;
  if (plan.problems.empty()) {
    if (at_corner) {
      const Iso3 here = plan.samples.back().T_base_tcp;
      b.checked(
          [&] {
            return b.line(here, backed_off(here, setting.approach_m), Phase::kDeparture, "final departure");
          },
          false, "final departure");
    }
    if (plan.problems.empty())
      b.checked([&] { return b.transit(setting.home, "transit home"); }, false, "transit home");
  }
  if (plan.problems.empty()) {
    plan.problems = check_joint_limits(plan.samples, robot, setting.sample_hz);
    if (!plan.problems.empty()) plan.failure = PlanFailure::kJointLimits;
  } else if (plan.failure == PlanFailure::kNone) {
    plan.failure = PlanFailure::kBlockedMove;  // the final departure or the transit home
  }
  return plan;
}

std::vector<std::string> check_joint_limits(const std::vector<PlanSample>& samples, const RobotModel& robot,
                                            double sample_hz) {
  return check_joint_limits(samples.data(), samples.size(), robot, sample_hz);
}

std::vector<std::string> check_joint_limits(const PlanSample* first, size_t count, const RobotModel& robot,
                                            double sample_hz) {
  const auto samples = [&](size_t k) -> const PlanSample& { return first[k]; };
  std::vector<std::string> out;
  double worst_v[6] = {0}, worst_a[6] = {0};
  int at_v[6] = {0}, at_a[6] = {0};
  for (size_t k = 0; k < count; ++k) {
    const JointVector& q = samples(k).q;
    for (int j = 0; j < 6; ++j)
      if (q[j] < robot.lower()[j] || q[j] > robot.upper()[j]) {
        out.push_back("joint " + std::to_string(j + 1) +
                      " leaves its limits at t = " + std::to_string(samples(k).t_s) + " s");
        return out;
      }
    if (k + 1 < count) {
      const JointVector v = (samples(k + 1).q - q) * sample_hz;
      for (int j = 0; j < 6; ++j)
        if (std::abs(v[j]) > worst_v[j]) {
          worst_v[j] = std::abs(v[j]);
          at_v[j] = static_cast<int>(k);
        }
    }
    if (k > 0 && k + 1 < count) {
      const JointVector a = (samples(k + 1).q - 2.0 * q + samples(k - 1).q) * sample_hz * sample_hz;
      for (int j = 0; j < 6; ++j)
        if (std::abs(a[j]) > worst_a[j]) {
          worst_a[j] = std::abs(a[j]);
          at_a[j] = static_cast<int>(k);
        }
    }
  }
  // A small tolerance for the finite differences of exact LSPB profiles.
  for (int j = 0; j < 6; ++j) {
    if (worst_v[j] > robot.max_velocity()[j] * 1.001)
      out.push_back("joint " + std::to_string(j + 1) + " needs " + std::to_string(worst_v[j]) +
                    " rad/s at t = " + std::to_string(samples(static_cast<size_t>(at_v[j])).t_s) +
                    " s (limit " + std::to_string(robot.max_velocity()[j]) + ")");
    if (worst_a[j] > robot.max_acceleration()[j] * 1.001)
      out.push_back("joint " + std::to_string(j + 1) + " needs " + std::to_string(worst_a[j]) +
                    " rad/s^2 at t = " + std::to_string(samples(static_cast<size_t>(at_a[j])).t_s) +
                    " s (limit " + std::to_string(robot.max_acceleration()[j]) + ")");
  }
  return out;
}

}  // namespace weldtwin
