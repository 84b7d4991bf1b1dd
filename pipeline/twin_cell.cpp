#include "pipeline/twin_cell.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/verdict.hpp"
#include "perception/localizer.hpp"
#include "perception/pose_error.hpp"

namespace weldtwin {
namespace {

// A rescan starts where the program before it ends: each joint within this.
constexpr double kSameJoint_rad = 1e-6;

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
      symmetry(z_symmetry_order(mesh)),
      turn_matters(!seams_turn_onto_themselves(seam_points)) {}

std::string TwinCell::sweep_again_because(const PoseEstimate& pose, size_t rescanned) const {
  if (rescanned >= rescans.size()) return "";
  // The table seen off the cell's: the LiDAR's mount is off, and every sweep through it is off alike.
  if (pose.table_off) return "";
  if (!pose.found) return "the part was not found";
  // The bounds' 99 % region against their 95 % one, for many cells (chi-square's 3-dof quantiles).
  PoseUncertaintySetting sure;
  sure.confidence = kRescanUnlessConfidence;
  constexpr double kMany = std::numeric_limits<double>::infinity();
  const double widen = std::sqrt(confidence_scale2(kMany, sure) / confidence_scale2(kMany));
  const double yaw_tolerance_rad = deg2rad(VerdictSetting().yaw_tolerance_deg);
  char buf[240] = "";
  if (widen * pose.seam_error_bound_m > part.weld_tolerance_m)
    std::snprintf(buf, sizeof buf,
                  "the part was found, its seams within %.2f mm (%.0f %%) but %.2f mm at %.0f %% (tolerance "
                  "%.2f mm)",
                  1e3 * pose.seam_error_bound_m, 100 * PoseUncertaintySetting().confidence,
                  1e3 * widen * pose.seam_error_bound_m, 100 * kRescanUnlessConfidence,
                  1e3 * part.weld_tolerance_m);
  else if (turn_matters && widen * pose.yaw_bound_rad > yaw_tolerance_rad)
    std::snprintf(buf, sizeof buf,
                  "the part was found, its turn within %.2f deg (%.0f %%) but %.2f deg at %.0f %% (tolerance "
                  "%.2f deg)",
                  rad2deg(pose.yaw_bound_rad), 100 * PoseUncertaintySetting().confidence,
                  rad2deg(widen * pose.yaw_bound_rad), 100 * kRescanUnlessConfidence,
                  rad2deg(yaw_tolerance_rad));
  return buf;
}

}  // namespace weldtwin
