// Survey: how often the weld planner can weld a part at random poses of the cell's placement ring, why it
// refuses the others, and how long planning takes.
//   plan_survey [--layouts N] [--seed S] CELL.yaml...
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "benchmarks/survey_args.hpp"
#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "planning/weld_planner.hpp"
#include "sim/cell_layout.hpp"

using namespace weldtwin;

int main(int argc, char** argv) {
  const SurveyArgs args(argc, argv, "plan_survey", 100);
  if (args.help) return 0;
  const int layouts = args.layouts;
  const uint64_t seed0 = args.seed;
  const std::vector<std::string>& cells = args.cells;
  try {
    for (const std::string& file : cells) {
      const CellSpec spec = CellSpec::load(file);
      const PartSpec part = PartSpec::load(spec.part_spec);
      const RobotModel robot = load_cell_robot(spec);
      int ok = 0, regrips = 0;
      std::map<std::string, int> refusals;
      std::vector<double> ms;
      for (int k = 0; k < layouts; ++k) {
        const CellLayout layout = make_layout(spec, part, seed0 + static_cast<uint64_t>(k));
        const auto t0 = std::chrono::steady_clock::now();
        const WeldPlan plan = plan_welds(part, layout.T_base_part, robot);
        ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        ok += plan.ok();
        regrips += !plan.notes.empty();
        if (!plan.ok()) {
          std::string why = plan.problems.front();
          why = why.substr(0, why.find(" ("));
          const auto at = why.find(" at t =");
          refusals[at == std::string::npos ? why : why.substr(0, at)]++;
        }
      }
      std::sort(ms.begin(), ms.end());
      std::printf(
          "%s (%d layouts): planned %d (%.0f %%), with re-grips %d; plan time median %.1f ms, max %.1f ms\n",
          part.name.c_str(), layouts, ok, 100.0 * ok / layouts, regrips, ms[ms.size() / 2], ms.back());
      for (const auto& [why, n] : refusals) std::printf("  refused %3d: %s\n", n, why.c_str());
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "plan_survey: %s\n", e.what());
    return 2;
  }
  return 0;
}
