#include "planning/plan_builder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "planning/free_path.hpp"
#include "planning/lspb.hpp"

namespace weldtwin {
namespace planner {

double Builder::margin(const IkSolution& s) const {
  const double limits = std::min((s.q - robot_.lower()).minCoeff(), (robot_.upper() - s.q).minCoeff());
  const double singular = std::min({s.shoulder_margin, s.elbow_margin, s.wrist_margin});
  if (limits < set_.min_margin_rad || singular < set_.min_singularity_sine) return -1.0;
  return std::min(limits, singular);
}

Choice Builder::choose(const SeamGeometry& g, double s0, double s1, std::optional<double> fixed_roll,
                       int prefer_branch) const {
  std::vector<double> rolls;
  if (fixed_roll) {
    rolls.push_back(*fixed_roll);
  } else {
    for (double r = -kPi; r < kPi - 1e-9; r += set_.roll_step_rad) rolls.push_back(r);
  }
  const int stations = std::max(6, static_cast<int>((s1 - s0) / kStationSpacing_m));
  // Every roll and branch that reaches the stretch within the margins, with its margin (the preferred
  // branch's raised): found by IK alone, before the cell is asked anything.
  struct Candidate {
    double roll = 0.0;
    int branch = -1;
    double margin = -1.0;
    JointVector first, last;                               ///< at the approach pose; at the last station
    std::vector<std::pair<JointVector, bool>> stations_q;  ///< for the collision test
  };
  // The torch at every station before its roll, shared by the rolls: the stretch's start (its approach pose
  // too, backed off), the stations, its end (the departure pose).
  std::vector<SeamGeometry::Station> at;
  at.reserve(static_cast<size_t>(stations) + 2);
  at.push_back(g.station(s0));
  for (int k = 1; k <= stations; ++k) at.push_back(g.station(s0 + (s1 - s0) * k / stations));
  at.push_back(g.station(s1));
  std::vector<Candidate> candidates;
  for (double roll : rolls) {
    std::array<double, 8> worst;
    worst.fill(std::numeric_limits<double>::infinity());
    std::array<JointVector, 8> last, first;
    last.fill(q_);  // J6 where it is free, until branch 0 reaches a station
    first.fill(q_);
    std::array<IkSolution, 8> fresh;
    std::array<std::vector<std::pair<JointVector, bool>>, 8> stations_q;
    // Stations along the stretch, plus its approach (k = -1) and departure (k = stations + 1) poses.
    for (int k = -1; k <= stations + 1; ++k) {
      const Iso3 pose = k < 0          ? backed_off(SeamGeometry::tcp(at.front(), roll), set_.approach_m)
                        : k > stations ? backed_off(SeamGeometry::tcp(at.back(), roll), set_.approach_m)
                                       : SeamGeometry::tcp(at[static_cast<size_t>(k)], roll);
      // Past the start, only the branches still reaching (and branch 0, whose J6 is the next reference).
      unsigned reaching = 1u;
      for (int b = 1; b < 8; ++b)
        if (worst[static_cast<size_t>(b)] >= 0) reaching |= 1u << b;
      const std::array<IkSolution, 8>& sols = k <= 0 ? solve_start(pose, k < 0 ? q_[5] : last[0][5])
                                                     : (fresh = ik_.solve(pose, last[0][5], reaching));
      for (int b = 0; b < 8; ++b) {
        const IkSolution& s = sols[static_cast<size_t>(b)];
        double m = s.valid && s.within_limits ? margin(s) : -1.0;
        if (m >= 0 && k > 0 && k <= stations &&
            (s.q - last[static_cast<size_t>(b)]).cwiseAbs().maxCoeff() > 0.3)
          m = -1.0;
        worst[static_cast<size_t>(b)] = std::min(worst[static_cast<size_t>(b)], m);
        if (s.valid) last[static_cast<size_t>(b)] = s.q;
        if (set_.collision && m >= 0 && k >= 0 && k <= stations)
          stations_q[static_cast<size_t>(b)].emplace_back(s.q, true);
        if (k < 0) first[static_cast<size_t>(b)] = s.q;
      }
      // Stop on this roll once no branch reaches.
      if (std::all_of(worst.begin(), worst.end(), [](double m) { return m < 0.0; })) break;
    }
    for (int b = 0; b < 8; ++b) {
      if (worst[static_cast<size_t>(b)] < 0) continue;
      candidates.push_back({roll, b, worst[static_cast<size_t>(b)] + (b == prefer_branch ? 0.05 : 0.0),
                            first[static_cast<size_t>(b)], last[static_cast<size_t>(b)],
                            std::move(stations_q[static_cast<size_t>(b)])});
    }
  }
  // The cell is asked best first: the first candidate clear of it is the one with the largest margin among
  // the clear ones (equal margins in the order found), and no candidate below it is asked about at all.
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.margin > b.margin; });
  for (const Candidate& c : candidates) {
    const auto rejected = [&] {  // the best candidate a collision ruled out names the problem
      if (c.margin > rejected_margin_) {
        rejected_margin_ = c.margin;
        rejected_hit_ = last_hit_;
      }
    };
    // The stations, the ways in and out, then (the most configurations) what lies between the stations.
    if (collides(c.stations_q)) {
      rejected();
      continue;
    }
    const auto in = clear_way(SeamGeometry::tcp(at.front(), c.roll), c.branch, c.first);
    const auto out = in ? clear_way(SeamGeometry::tcp(at.back(), c.roll), c.branch, c.last) : std::nullopt;
    if (!in || !out) {
      if (!last_hit_.empty()) rejected();
      continue;
    }
    if (!clear_along(g, s0, s1, c.roll, c.branch, c.first)) {
      rejected();
      continue;
    }
    return {true, c.roll, c.branch, c.margin, in->second, in->first, out->first};
  }
  return Choice();
}

const std::array<IkSolution, 8>& Builder::solve_start(const Iso3& pose, double q6_reference) const {
  std::array<double, 13> key;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) key[static_cast<size_t>(4 * r + c)] = pose.matrix()(r, c);
  key[12] = q6_reference;
  if (const auto it = start_ik_.find(key); it != start_ik_.end()) return it->second;
  if (start_ik_.size() > 4096) start_ik_.clear();
  return start_ik_.emplace(key, ik_.solve(pose, q6_reference)).first->second;
}

bool Builder::clear_along(const SeamGeometry& g, double s0, double s1, double roll, int b,
                          const JointVector& q_near) const {
  if (!set_.collision) return true;
  // Grid points every kStationSpacing_m from the seam's start, so that the stretches tried for one seam (a
  // split's bisection tries many ends from one start) share their inner pieces, and each piece is asked once.
  std::vector<double> at{s0};
  for (double s = (std::floor(s0 / kStationSpacing_m + 1e-9) + 1) * kStationSpacing_m; s < s1 - 1e-9;
       s += kStationSpacing_m)
    at.push_back(s);
  at.push_back(s1);
  JointVector qa = q_near;
  bool have_a = false;
  for (size_t k = 0; k < at.size(); ++k) {
    const IkSolution end = ik_.solve_branch(g.tcp(at[k], roll), b, qa[5]);
    if (!end.valid) {  // the stations were reached; a pose between them that is not is the stations' matter
      have_a = false;
      continue;
    }
    if (have_a) {
      std::array<double, 12> key;
      for (int j = 0; j < 6; ++j)
        key[static_cast<size_t>(j)] = qa[j], key[static_cast<size_t>(j + 6)] = end.q[j];
      auto it = along_answers_.find(key);
      if (it == along_answers_.end()) {
        std::string hit;
        const double change = (end.q - qa).cwiseAbs().maxCoeff();
        const int n = std::min(64, static_cast<int>(std::ceil(change / set_.collision_step_rad - 1e-9)));
        JointVector prev = qa;
        for (int i = 1; i < n && hit.empty(); ++i) {
          const IkSolution sol =
              ik_.solve_branch(g.tcp(at[k - 1] + (at[k] - at[k - 1]) * i / n, roll), b, prev[5]);
          if (!sol.valid) continue;
          hit = collision(sol.q, true);
          prev = sol.q;
        }
        if (along_answers_.size() > 200000) along_answers_.clear();
        it = along_answers_.emplace(key, hit).first;
      }
      if (!it->second.empty()) {
        last_hit_ = it->second;
        return false;
      }
    }
    qa = end.q;
    have_a = true;
  }
  return true;
}

void Builder::rewind(const Mark& m) {
  plan_.samples.resize(m.samples);
  plan_.problems.resize(m.problems);
  q_ = m.q;
  t_ = m.t;
  branch_ = m.branch;
}

bool Builder::collides(const std::vector<std::pair<JointVector, bool>>& qs) const {
  if (!set_.collision) return false;
  for (const auto& [q, welding] : qs) {
    std::string hit = collision(q, welding);
    if (hit.empty()) continue;
    last_hit_ = hit;
    return true;
  }
  return false;
}

std::string Builder::collision(const JointVector& q, bool welding) const {
  const ConfigKey key{q[0], q[1], q[2], q[3], q[4], q[5], welding ? 1.0 : 0.0};
  if (const auto it = answers_.find(key); it != answers_.end()) return it->second;
  if (answers_.size() > 200000) answers_.clear();
  std::string hit = set_.collision(q, welding);
  answers_.emplace(key, hit);
  return hit;
}

std::optional<std::pair<Vec3, JointVector>> Builder::clear_way(const Iso3& at, int b,
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

std::string Builder::main_collision() const {
  std::string what = rejected_hit_;
  rejected_hit_.clear();
  rejected_margin_ = -1.0;
  return what;
}

std::string Builder::collision_since(size_t from) const {
  std::string what;
  if (!set_.collision) return what;
  const std::vector<PlanSample>& s = plan_.samples;
  // Sample k is asked when the next one would lie farther than the step from the last one asked: most of a
  // transit's samples are the slow ends of its moves and the approaches (under 2 mrad apart), while at speed
  // a sample turns a joint 5-10 mrad.
  const JointVector* asked = nullptr;
  for (size_t k = from; k < s.size(); ++k) {
    const bool last = k + 1 == s.size();
    const bool ask = !asked || last || s[k + 1].arc != s[k].arc ||
                     (s[k + 1].q - *asked).cwiseAbs().maxCoeff() > set_.transit_check_rad;
    if (!ask) continue;
    if (!(what = set_.collision(s[k].q, s[k].arc)).empty()) break;
    asked = &s[k].q;
  }
  return what;
}

Builder::Ran Builder::transit(const JointVector& to, const std::string& what) {
  const Mark start = mark();
  joint_move(to);
  std::string hit = collision_since(start.samples);
  if (hit.empty()) return Ran::kOk;
  rewind(start);
  const Iso3 here = tcp_pose(q_), there = tcp_pose(to);
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
      [&](const JointVector& q) { return set_.collision(q, false).empty(); }, set_.transit_check_rad);
  // Its segments are asked `transit_check_rad` apart along the straight joint-space lines (the step of every
  // transit's check: at 20 mrad the search took the straight line that the check of the timed samples had
  // just refused); the timed samples are then asked as every transit's are, and a path whose samples meet
  // something between two of the search's questions is not taken.
  if (!path.empty()) {
    for (size_t k = 1; k < path.size(); ++k) joint_move(path[k]);
    if ((q_ - to).cwiseAbs().maxCoeff() < 1e-9 && collision_since(start.samples).empty()) return Ran::kOk;
    rewind(start);
  }
  problem(what + ": collides with " + hit +
          (joint_space_search_available()
               ? " (straight, lifted, by way of home, or any way found in joint space)"
               : " (straight, lifted or by way of home; this weldtwin was built without OMPL "
                 "(WELDTWIN_WITH_OMPL=OFF), which searches joint space for a way around)"));
  return Ran::kBlocked;
}

bool Builder::leg_out_across_in(const Iso3& here, const Iso3& out, bool via_home, const Iso3& in,
                                const Iso3& there, const JointVector& to, const std::string& what) {
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

int Builder::branch_of(const Iso3& T, const JointVector& q) const {
  for (int b = 0; b < 8; ++b) {
    const IkSolution s = ik_.solve_branch(T, b, q[5]);
    if (!s.valid) continue;
    bool same = true;
    for (int j = 0; j < 6; ++j) same &= std::abs(std::remainder(s.q[j] - q[j], 2.0 * kPi)) < 1e-6;
    if (same) return b;
  }
  return -1;
}

bool Builder::add(const Iso3& T, int seam, Phase phase, const std::string& what) {
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

void Builder::joint_move(const JointVector& to) {
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
    plan_.samples.push_back({t_, q_, tcp_pose(q_), -1, false, Phase::kTransit});
  }
}

bool Builder::line(const Iso3& from, const Iso3& to, Phase phase, const std::string& what) {
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

bool Builder::weld(const SeamGeometry& g, double s0, double s1, double roll, int seam_index) {
  const Lspb law = Lspb::with_blend_fraction(s1 - s0, g.seam->speed_m_s, set_.blend_fraction);
  const int n = static_cast<int>(std::ceil(law.duration / dt_ - 1e-9));
  for (int k = 1; k <= n; ++k) {
    double s, sd, sdd;
    law.at(k * dt_, s, sd, sdd);
    if (!add(g.tcp(s0 + s, roll), seam_index, Phase::kWeld, "seam '" + g.seam->name + "'")) return false;
  }
  return true;
}

bool Builder::corner(const Iso3& from, const Iso3& to, int seam_index, const std::string& what) {
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
    if (!add(make_transform(from.translation(), a.slerp(s, b).toRotationMatrix()), seam_index, Phase::kCorner,
             what))
      return false;
  }
  return true;
}

}  // namespace planner
}  // namespace weldtwin
