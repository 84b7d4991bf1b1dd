#include "planning/weld_planner.hpp"

#include <algorithm>
#include <optional>
#include <sstream>

#include "planning/plan_builder.hpp"

namespace weldtwin {
namespace {

using planner::backed_off;
using planner::Builder;
using planner::Choice;
using planner::moved;
using planner::SeamGeometry;

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

WeldPlan plan_welds(const PartSpec& part, const Iso3& T_base_part, const RobotModel& robot,
                    const PlanSetting& setting) {
  WeldPlan plan;
  const JointVector zero = JointVector::Zero();
  plan.T_flange_tcp = robot.forward_kinematics(zero, robot.require_link("flange")).inverse() *
                      robot.forward_kinematics(zero, robot.require_link("tcp"));
  Builder b(robot, setting, plan);
  plan.samples.reserve(32768);
  const JointVector first = setting.start.value_or(setting.home);
  plan.samples.push_back({0.0, first, b.tcp_pose(first), -1, false, Phase::kTransit});
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
        Choice c = b.choose(g, s0, g.length, seam.torch_roll_rad, branch);
        double s1 = g.length;
        if (!c.ok && seam.kind == Seam::Kind::kArc && !seam.torch_roll_rad) {
          // The longest stretch from s0 that some roll can weld, by bisection on its end.
          // The choice for the longest stretch found is kept (choose answers the same for the same stretch).
          double lo = s0, hi = g.length;
          std::optional<Choice> at_lo;
          for (int it = 0; it < 7; ++it) {
            const double mid = 0.5 * (lo + hi);
            if (Choice m = b.choose(g, s0, mid, seam.torch_roll_rad, branch); m.ok) {
              lo = mid;
              at_lo = m;
            } else {
              hi = mid;
            }
          }
          s1 = lo;
          c = at_lo ? *at_lo : b.choose(g, s0, s1, seam.torch_roll_rad, branch);
          // Leave no stub too short to blend at the weld speed: end this piece earlier instead.
          constexpr double kMinPiece = 0.025;
          if (g.length - s1 < kMinPiece && g.length - kMinPiece - s0 >= 0.01) {
            s1 = g.length - kMinPiece;
            c = b.choose(g, s0, s1, seam.torch_roll_rad, branch);
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
          const Choice c = b.choose(g, a, e, seam.torch_roll_rad, branch);
          if (!c.ok) break;
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
        nominal_kind = !split_failed    ? b.last_failure()
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

}  // namespace weldtwin
