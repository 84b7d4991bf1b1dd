// Survey: how often the weld planner can weld a part at random poses of the cell's placement area, why it
// refuses the others, and how long planning takes.
//   plan_survey [--layouts N] [--seed S] [--in-cell] [--placement ring|table] CELL.yaml...
// --in-cell plans as `weldtwin run` and `weldtwin bench` do: against the cell's table, clamps and clutter and
// the part's exact mesh (the twin's CollisionChecker, one per layout), and says how many collision questions
// the planner asked and what share of its time they took. Without it: kinematics and limits only.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "benchmarks/survey_args.hpp"
#include "core/error.hpp"
#include "pipeline/twin_cell.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"
#include "sim/collision_check.hpp"
#include "sim/mujoco_world.hpp"

using namespace weldtwin;

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

}  // namespace

int main(int argc, char** argv) {
  // The options of this survey alone, taken out before the shared ones are parsed.
  bool in_cell = false;
  std::optional<PlacementSpec::Area> area;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--in-cell")) {
      in_cell = true;
    } else if (!std::strcmp(argv[i], "--placement") && i + 1 < argc) {
      area = placement_area_from(argv[++i]);
      if (!area) {
        std::fprintf(stderr, "plan_survey: --placement is ring or table, not %s\n", argv[i]);
        return 2;
      }
    } else {
      rest.push_back(argv[i]);
    }
  }
  const SurveyArgs args(static_cast<int>(rest.size()), rest.data(), "plan_survey", 100);
  if (args.help) {
    std::printf(
        "  --in-cell            plan against the cell and the part's mesh, as run and bench do\n"
        "  --placement AREA     ring or table (default: each cell's own)\n");
    return 0;
  }
  try {
    for (const std::string& file : args.cells) {
      CellSpec spec = CellSpec::load(file);
      if (area) spec.placement.area = *area;
      const TwinCell c(spec);
      int ok = 0, regrips = 0;
      std::map<std::string, int> refusals;
      std::vector<double> ms, query_ms, queries, checker_ms;
      for (int k = 0; k < args.layouts; ++k) {
        const CellLayout layout = make_layout(c.cell, c.part, args.seed + static_cast<uint64_t>(k));
        PlanSetting setting;
        std::optional<MujocoWorld> world;
        size_t asked = 0;
        double asked_ms = 0.0;
        std::optional<CollisionChecker> checker;
        if (in_cell) {
          world.emplace(c.cell, c.part, c.robot, layout);
          const auto t_checker = Clock::now();
          checker.emplace(*world);
          checker->add_part(c.mesh, layout.T_base_part);
          checker_ms.push_back(ms_since(t_checker));
          setting.collision = [&](const JointVector& q, bool welding) {
            const auto t0 = Clock::now();
            std::string hit = (*checker)(q, welding);
            asked_ms += ms_since(t0);
            ++asked;
            return hit;
          };
        }
        const auto t0 = Clock::now();
        const WeldPlan plan = plan_welds(c.part, layout.T_base_part, c.robot, setting);
        ms.push_back(ms_since(t0));
        query_ms.push_back(asked_ms);
        queries.push_back(static_cast<double>(asked));
        ok += plan.ok();
        regrips += !plan.notes.empty();
        if (!plan.ok()) {
          std::string why = plan.problems.front();
          why = why.substr(0, why.find(" ("));
          const auto at = why.find(" at t =");
          refusals[at == std::string::npos ? why : why.substr(0, at)]++;
        }
      }
      std::printf(
          "%s (%d layouts%s): planned %d (%.0f %%), with notes %d; plan time median %.1f ms, p90 %.1f ms, "
          "max %.1f ms\n",
          c.part.name.c_str(), args.layouts, in_cell ? ", in the cell" : "", ok, 100.0 * ok / args.layouts,
          regrips, percentile(ms, 0.5), percentile(ms, 0.9), percentile(ms, 1.0));
      if (in_cell) {
        double total = 0.0, asked = 0.0, n = 0.0;
        for (size_t k = 0; k < ms.size(); ++k) total += ms[k], asked += query_ms[k], n += queries[k];
        std::printf(
            "  collision questions: median %.0f a plan (%.1f us each), %.0f %% of the planning time; the "
            "checker's making (before planning) median %.1f ms\n",
            percentile(queries, 0.5), 1e3 * asked / std::max(1.0, n), 100.0 * asked / total,
            percentile(checker_ms, 0.5));
      }
      for (const auto& [why, n] : refusals) std::printf("  refused %3d: %s\n", n, why.c_str());
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "plan_survey: %s\n", e.what());
    return 2;
  }
  return 0;
}
