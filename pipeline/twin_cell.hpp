// A cell as the twin runs it, loaded once: the cell file, its part (spec, mesh, seams), the robot it names
// and its sweep program. Every job on the cell (a run, each bench trial, each survey cell) starts from one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/mesh_io.hpp"
#include "sim/sweep_program.hpp"

namespace weldtwin {

struct PoseEstimate;

/// The twin's k-th rescan (from 0) draws its LiDAR noise from the sweep's seed plus k + 1 times this (a
/// sweep of its own).
constexpr uint64_t kRescanLidarSeedOffset = 1000003;
inline uint64_t rescan_lidar_seed(uint64_t sweep_seed, size_t k) {
  return sweep_seed + (k + 1) * kRescanLidarSeedOffset;
}

/// While a rescan is left, a pose found is taken only where its bounds at this confidence are within the
/// tolerances (TwinCell::sweep_again_because).
constexpr double kRescanUnlessConfidence = 0.99;

struct TwinCell {
  CellSpec cell;
  PartSpec part;
  RobotModel robot;  ///< as the controller knows it (the URDF's LiDAR mount)
  SweepProgram program;
  /// Swept one after another while the part is not found, or found short of the 99 % bar
  /// (CellSpec::rescan_programs, sweep_again_because): the first starts where `program` ends, each other
  /// where the one before it ends
  std::vector<SweepProgram> rescans;
  Mesh mesh;                      ///< the part's CAD, metres
  std::vector<Vec3> seam_points;  ///< part frame, 1 mm apart: what seam errors are measured on
  int symmetry = 1;               ///< z_symmetry_order of the mesh
  bool turn_matters = true;       ///< the seams do not turn onto themselves (the part's yaw moves the weld)

  /// Loads what `cell` names; `sweep_file` ("" = the cell's own) replaces its sweep program, and with it the
  /// cell's rescans, unless `rescan_files` name others. Throws InputError naming the file that is wrong (a
  /// rescan that does not start where the program before it ends, too).
  explicit TwinCell(CellSpec cell, const std::string& sweep_file = "",
                    const std::vector<std::string>& rescan_files = {});

  /// Why the cell sweeps its next rescan when the sweeps so far (the first and `rescanned` rescans) gave
  /// `pose` ("": it does not). It does while it has one left and the part (or what was sought) was not found,
  /// or was found with a pose that the 99 % confidence region would not accept: the verdict's bar is the
  /// 95 % region, and while another sweep can be had it costs less than a weld that may be off. Not when the
  /// scan showed the table off the cell's (PoseEstimate::table_off): the LiDAR's mount is off, and another
  /// sweep through it would be off alike. Every caller that sweeps asks this.
  std::string sweep_again_because(const PoseEstimate& pose, size_t rescanned) const;
  bool sweeps_again(const PoseEstimate& pose, size_t rescanned) const {
    return !sweep_again_because(pose, rescanned).empty();
  }
};

}  // namespace weldtwin
