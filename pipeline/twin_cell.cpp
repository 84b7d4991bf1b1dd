#include "pipeline/twin_cell.hpp"

#include <cstdio>
#include <utility>

#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "perception/localizer.hpp"
#include "perception/pose_error.hpp"

namespace weldtwin {
namespace {

constexpr double kSameJoint_rad =
    1e-6;  // a rescan starts where the program before ends: each joint within this

// The rescans a cell sweeps: `rescan_files`, or else the cell's own unless another sweep replaced its own;
// each must start where the program before it ends.
std::vector<SweepProgram> load_rescans(const CellSpec& cell, const std::string& sweep_file,
                                       const std::vector<std::string>& rescan_files,
                                       const SweepProgram& sweep, const RobotModel& robot) {
  const std::vector<std::string> files = !rescan_files.empty() ? rescan_files
                                         : sweep_file.empty()  ? cell.rescan_programs
                                                               : std::vector<std::string>{};
  std::vector<SweepProgram> out;
  for (const std::string& file : files) {
    const SweepProgram& before = out.empty() ? sweep : out.back();
    SweepProgram rescan = SweepProgram::load(file, robot);
    const JointVector end = before.moves().empty() ? before.start() : before.moves().back().to;
    int j = 0;
    if ((rescan.start() - end).cwiseAbs().maxCoeff(&j) > kSameJoint_rad) {
      char buf[400];
      std::snprintf(
          buf, sizeof buf,
          "a rescan starts where the %s before it (%s) ends: its start_deg has joint %d at %.2f deg, "
          "that program ends at %.2f deg",
          out.empty() ? "sweep" : "rescan", before.source().c_str(), j + 1, rad2deg(rescan.start()[j]),
          rad2deg(end[j]));
      throw input_error(file, buf);
    }
    out.push_back(std::move(rescan));
  }
  return out;
}

}  // namespace

TwinCell::TwinCell(CellSpec cell_in, const std::string& sweep_file,
                   const std::vector<std::string>& rescan_files)
    : cell(std::move(cell_in)),
      part(PartSpec::load(cell.part_spec)),
      robot(load_cell_robot(cell)),
      program(SweepProgram::load(sweep_file.empty() ? cell.sweep_program : sweep_file, robot)),
      rescans(load_rescans(cell, sweep_file, rescan_files, program, robot)),
      mesh(load_mesh(part.mesh_path)),
      seam_points(part.seam_points(0.001)),
      symmetry(z_symmetry_order(mesh)) {}

bool TwinCell::sweeps_again(const PoseEstimate& pose, size_t rescanned) const {
  return rescanned < rescans.size() && !pose.found;
}

}  // namespace weldtwin
