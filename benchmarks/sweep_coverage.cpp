// Survey: does the cell's sweep see every seam of a part placed anywhere within reach? Draws seeded layouts
// (any yaw, 2-4 clamps, clutter), sweeps them noise-free and reports, per part and seam, the fraction of seam
// stations seen on both members, and the part point counts.
//   sweep_coverage [--layouts N] [--seed S] CELL.yaml...
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "benchmarks/survey_args.hpp"
#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/seam_coverage.hpp"
#include "sim/sweep_sim.hpp"

using namespace weldtwin;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * static_cast<double>(v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  const SurveyArgs args(argc, argv, "sweep_coverage", 20);
  if (args.help) return 0;
  const int layouts = args.layouts;
  const uint64_t seed0 = args.seed;
  const std::vector<std::string>& cells = args.cells;
  try {
    for (const std::string& file : cells) {
      const CellSpec spec = CellSpec::load(file);
      const PartSpec part = PartSpec::load(spec.part_spec);
      const RobotModel robot = load_cell_robot(spec);
      const SweepProgram program = SweepProgram::load(spec.sweep_program, robot);
      std::vector<std::vector<double>> seen(part.seams.size()), seen_one(part.seams.size());
      std::vector<double> part_points;
      std::vector<int> fully(part.seams.size(), 0), blind(part.seams.size(), 0);
      for (int k = 0; k < layouts; ++k) {
        const CellLayout layout = make_layout(spec, part, seed0 + static_cast<uint64_t>(k));
        const MujocoWorld world(spec, part, robot, layout);
        const SweepResult r = simulate_sweep(world, robot, program, LidarSetting().noise_free());
        const AssembledCloud cloud = assemble_scan(r.log, robot);
        std::vector<Vec3> pts;
        for (size_t i = 0; i < cloud.points_base.size(); ++i)
          if (r.labels[cloud.sample_index[i]] == Label::kPart) pts.push_back(cloud.points_base[i]);
        part_points.push_back(static_cast<double>(pts.size()));
        const auto cov = seam_coverage(part, layout.T_base_part, pts);
        for (size_t s = 0; s < cov.size(); ++s) {
          seen[s].push_back(cov[s].fraction());
          seen_one[s].push_back(cov[s].fraction_one());
          fully[s] += cov[s].fraction() >= 0.9;
          blind[s] += cov[s].fraction() < 0.25;
        }
        std::fprintf(stderr, "\r%s: layout %d/%d", part.name.c_str(), k + 1, layouts);
      }
      std::fprintf(stderr, "\n");
      std::printf("%s (%d layouts): part points median %.0f, min %.0f\n", part.name.c_str(), layouts,
                  percentile(part_points, 0.5), percentile(part_points, 0.0));
      for (size_t s = 0; s < part.seams.size(); ++s)
        std::printf(
            "  seam %-6s both members: median %.2f, p10 %.2f, min %.2f; >= 90 %% in %d, < 25 %% in %d | "
            "one member at least: median %.2f, min %.2f\n",
            part.seams[s].name.c_str(), percentile(seen[s], 0.5), percentile(seen[s], 0.1),
            percentile(seen[s], 0.0), fully[s], blind[s], percentile(seen_one[s], 0.5),
            percentile(seen_one[s], 0.0));
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "sweep_coverage: %s\n", e.what());
    return 2;
  }
  return 0;
}
