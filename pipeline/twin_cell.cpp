#include "pipeline/twin_cell.hpp"

#include <cstdio>
#include <utility>

#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "perception/localizer.hpp"
#include "perception/pose_error.hpp"

namespace weldtwin {
namespace {

constexpr double kSameJoint_rad = 1e-6;  // a rescan starts where the sweep ends: each joint within this

std::optional<SweepProgram> load_rescan(const CellSpec& cell, const std::string& sweep_file,
                                        const std::string& rescan_file, const SweepProgram& sweep,
                                        const RobotModel& robot) {
  const std::string file = !rescan_file.empty() ? rescan_file : sweep_file.empty() ? cell.rescan_program : "";
  if (file.empty()) return std::nullopt;
  SweepProgram rescan = SweepProgram::load(file, robot);
  const JointVector end = sweep.moves().empty() ? sweep.start() : sweep.moves().back().to;
  int j = 0;
  if ((rescan.start() - end).cwiseAbs().maxCoeff(&j) > kSameJoint_rad) {
    char buf[400];
    std::snprintf(
        buf, sizeof buf,
        "a rescan starts where the sweep (%s) ends: its start_deg has joint %d at %.2f deg, the sweep "
        "ends at %.2f deg",
        sweep.source().c_str(), j + 1, rad2deg(rescan.start()[j]), rad2deg(end[j]));
    throw input_error(file, buf);
  }
  return rescan;
}

}  // namespace

TwinCell::TwinCell(CellSpec cell_in, const std::string& sweep_file, const std::string& rescan_file)
    : cell(std::move(cell_in)),
      part(PartSpec::load(cell.part_spec)),
      robot(load_cell_robot(cell)),
      program(SweepProgram::load(sweep_file.empty() ? cell.sweep_program : sweep_file, robot)),
      rescan(load_rescan(cell, sweep_file, rescan_file, program, robot)),
      mesh(load_mesh(part.mesh_path)),
      seam_points(part.seam_points(0.001)),
      symmetry(z_symmetry_order(mesh)) {}

bool TwinCell::sweeps_again(const PoseEstimate& pose) const {
  return rescan && !pose.found;
}

}  // namespace weldtwin
