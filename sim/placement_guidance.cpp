#include "sim/placement_guidance.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "sim/collision_check.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {
namespace {

double yaw_of(const Iso3& T) {
  return std::atan2(T.linear()(1, 0), T.linear()(0, 0));
}

// The angle in (-pi, pi].
double wrapped(double a) {
  a = std::remainder(a, 2 * kPi);
  return a <= -kPi ? a + 2 * kPi : a;
}

struct Candidate {
  double cost = 0.0, x = 0.0, y = 0.0, yaw = 0.0, move = 0.0, turn = 0.0;
};

}  // namespace

CellSpec cell_as_laid_out(const CellSpec& cell_file, const CellLayout& now) {
  CellSpec cell = cell_file;
  cell.placement.area = PlacementSpec::Area::kTable;
  cell.clamp_sites.clear();
  for (const ClampPlacement& c : now.clamps) cell.clamp_sites.push_back(c.site);
  cell.clutter = now.clutter;
  return cell;
}

std::string placement_instruction(const Iso3& from, const Iso3& to) {
  std::ostringstream os;
  const double turn_deg = rad2deg(wrapped(yaw_of(to) - yaw_of(from)));
  const long turn = std::lround(std::abs(turn_deg));
  const Vec3 d = to.translation() - from.translation();
  const Eigen::Vector2d p(from.translation().x(), from.translation().y());
  const Eigen::Vector2d out = p.norm() > 1e-6 ? Eigen::Vector2d(p / p.norm()) : Eigen::Vector2d::UnitX();
  const Eigen::Vector2d left(-out.y(), out.x());  // counter-clockwise round the robot: the robot's left
  const double radial = d.x() * out.x() + d.y() * out.y(), side = d.x() * left.x() + d.y() * left.y();
  const auto five_mm = [](double m) { return 5 * std::lround(std::abs(m) * 1e3 / 5.0); };
  std::vector<std::string> moves;
  if (five_mm(radial) > 0)
    moves.push_back(std::to_string(five_mm(radial)) + " mm " + (radial < 0 ? "towards" : "away from") +
                    " the robot");
  if (five_mm(side) > 0)
    moves.push_back(std::to_string(five_mm(side)) + " mm to the robot's " + (side > 0 ? "left" : "right"));
  if (turn > 0)
    os << "turn the part " << turn << " deg " << (turn_deg < 0 ? "clockwise" : "counter-clockwise")
       << " (seen from above)";
  if (!moves.empty()) {
    os << (turn > 0 ? " and move it " : "move the part ") << moves[0];
    if (moves.size() > 1) os << " and " << moves[1];
  }
  if (turn == 0 && moves.empty()) os << "leave the part where it is";
  return os.str();
}

PlacementSuggestion suggest_placement(const CellSpec& cell_file, const PartSpec& part,
                                      const RobotModel& robot, const Mesh& mesh, const CellLayout& now,
                                      int symmetry_order, const GuidanceSetting& setting) {
  const auto started = std::chrono::steady_clock::now();
  PlacementSuggestion out;
  const auto finish = [&](PlacementSuggestion& s) {
    s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return s;
  };
  const CellSpec cell = cell_as_laid_out(cell_file, now);

  // Candidates nearest first. Turns that leave a symmetric part as it was are the same placement.
  const double x0 = now.T_base_part.translation().x(), y0 = now.T_base_part.translation().y();
  const double yaw0 = yaw_of(now.T_base_part);
  const double period = 2 * kPi / std::max(1, symmetry_order);
  const int steps = static_cast<int>(std::lround(setting.max_move_m / setting.grid_m));
  const int turns = std::max(1, static_cast<int>(std::lround(period / setting.yaw_step_rad)));
  std::vector<Candidate> candidates;
  for (int i = -steps; i <= steps; ++i)
    for (int j = -steps; j <= steps; ++j) {
      const double move = setting.grid_m * std::hypot(i, j);
      if (move > setting.max_move_m + 1e-9) continue;
      for (int k = 0; k < turns; ++k) {
        if (i == 0 && j == 0 && k == 0) continue;  // where it lies
        const double turn = wrapped(k * setting.yaw_step_rad);
        Candidate c;
        c.x = x0 + setting.grid_m * i;
        c.y = y0 + setting.grid_m * j;
        c.turn = std::remainder(turn, period);
        c.yaw = yaw0 + c.turn;
        c.move = move;
        c.cost = 1e3 * move + setting.mm_per_deg * std::abs(rad2deg(c.turn));
        candidates.push_back(c);
      }
    }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });

  const MujocoWorld world(cell, part, robot, now);
  CollisionChecker screen(world);
  screen.add_part(mesh, now.T_base_part);
  // Where the arm starts collides with what does not move with the part (clutter, the table): no placement
  // of the part helps.
  const JointVector start = setting.plan.start.value_or(setting.plan.home);
  if (const std::string hit = screen(start); !hit.empty() && hit.find("with the part") == std::string::npos &&
                                             hit.find("clamp") == std::string::npos) {
    out.reason = "the arm where it starts collides (" + hit +
                 "): clear that away first; moving the part does not help";
    return finish(out);
  }
  PlanSetting quick = setting.plan;
  quick.stations_only = true;
  quick.collision = screen;
  size_t unroomy = 0, near_failed = 0;
  std::vector<const Candidate*> failed;  // passed the station test, failed in full
  for (const Candidate& c : candidates) {
    if (out.screened >= static_cast<int>(setting.max_screened) || out.verified >= setting.max_verified) break;
    const bool near_a_failure = std::any_of(failed.begin(), failed.end(), [&](const Candidate* f) {
      return std::hypot(c.x - f->x, c.y - f->y) < setting.retry_apart_m &&
             std::abs(std::remainder(c.yaw - f->yaw, period)) < setting.retry_apart_rad;
    });
    if (near_a_failure) {
      ++near_failed;
      continue;
    }
    const CellLayout layout = layout_at(cell, part, planar_pose(c.x, c.y, cell.table.top_z_m, c.yaw));
    if (!layout_problem(cell, part, layout).empty()) {
      ++unroomy;
      continue;
    }
    ++out.screened;
    // The station test where asked, and as far off as an operator puts a part down (where there is room).
    const auto stations_clear = [&](double x, double y, double yaw) {
      const CellLayout l = layout_at(cell, part, planar_pose(x, y, cell.table.top_z_m, yaw));
      if (!layout_problem(cell, part, l).empty()) return true;
      screen.place(l);
      return plan_welds(part, l.T_base_part, robot, quick).ok();
    };
    // Off by up to the tolerance along x and along y: the square's sides and its corners.
    const double d = setting.placement_tolerance_m, a = setting.placement_tolerance_rad;
    bool clear = stations_clear(c.x, c.y, c.yaw) && stations_clear(c.x, c.y, c.yaw + a) &&
                 stations_clear(c.x, c.y, c.yaw - a);
    for (int i = -1; clear && i <= 1; ++i)
      for (int j = -1; clear && j <= 1; ++j)
        if (i != 0 || j != 0) clear = stations_clear(c.x + i * d, c.y + j * d, c.yaw);
    if (!clear) continue;
    // Planned in full and replayed, in the world with the part and its clamps there.
    ++out.verified;
    const MujocoWorld there(cell, part, robot, layout);
    CollisionChecker checker(there);
    checker.add_part(mesh, layout.T_base_part);
    PlanSetting full = setting.plan;
    full.stations_only = false;
    full.collision = checker;
    const WeldPlan plan = plan_welds(part, layout.T_base_part, robot, full);
    if (!plan.ok() || plan.samples.empty() ||
        !replay_plan(there, robot, plan, part, mesh, layout.T_base_part, setting.replay).passed()) {
      failed.push_back(&c);
      continue;
    }
    out.found = true;
    out.T_base_part = layout.T_base_part;
    out.move_m = c.move;
    out.turn_rad = c.turn;
    out.instruction = placement_instruction(now.T_base_part, layout.T_base_part);
    return finish(out);
  }
  std::ostringstream why;
  why << "no placement within " << std::lround(1e3 * setting.max_move_m) << " mm welds in the twin ("
      << out.screened << " with room screened, " << out.verified << " planned in full and replayed, "
      << unroomy << " without room for the part and its clamps, " << near_failed
      << " passed over beside ones that failed in full)";
  out.reason = why.str();
  return finish(out);
}

}  // namespace weldtwin
