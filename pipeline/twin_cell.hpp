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

/// The twin's rescan draws its LiDAR noise from the sweep's seed plus this (a sweep of its own).
constexpr uint64_t kRescanLidarSeedOffset = 1000003;

struct TwinCell {
  CellSpec cell;
  PartSpec part;
  RobotModel robot;  ///< as the controller knows it (the URDF's LiDAR mount)
  SweepProgram program;
  /// Swept when the part is not found in the first sweep (CellSpec::rescan_program); starts where `program`
  /// ends
  std::optional<SweepProgram> rescan;
  Mesh mesh;                      ///< the part's CAD, metres
  std::vector<Vec3> seam_points;  ///< part frame, 1 mm apart: what seam errors are measured on
  int symmetry = 1;               ///< z_symmetry_order of the mesh

  /// Loads what `cell` names; `sweep_file` ("" = the cell's own) replaces its sweep program, and with it the
  /// cell's rescan, unless `rescan_file` names one. Throws InputError naming the file that is wrong (a rescan
  /// that does not start where the sweep ends, too).
  explicit TwinCell(CellSpec cell, const std::string& sweep_file = "", const std::string& rescan_file = "");

  /// Whether the cell sweeps its rescan after a first sweep that gave `pose`: it has one, and the part (or
  /// what was sought) was not found. Every caller that sweeps asks this.
  bool sweeps_again(const PoseEstimate& pose) const;
};

}  // namespace weldtwin
