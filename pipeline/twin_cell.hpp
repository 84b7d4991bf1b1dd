// A cell as the twin runs it, loaded once: the cell file, its part (spec, mesh, seams), the robot it names
// and its sweep program. Every job on the cell (a run, each bench trial, each survey cell) starts from one.
#pragma once

#include <string>
#include <vector>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"
#include "core/robot_model.hpp"
#include "perception/mesh_io.hpp"
#include "sim/sweep_program.hpp"

namespace weldtwin {

struct TwinCell {
  CellSpec cell;
  PartSpec part;
  RobotModel robot;  ///< as the controller knows it (the URDF's LiDAR mount)
  SweepProgram program;
  Mesh mesh;                      ///< the part's CAD, metres
  std::vector<Vec3> seam_points;  ///< part frame, 1 mm apart: what seam errors are measured on
  int symmetry = 1;               ///< z_symmetry_order of the mesh

  /// Loads what `cell` names; `sweep_file` ("" = the cell's own) replaces its sweep program. Throws
  /// InputError naming the file that is wrong.
  explicit TwinCell(CellSpec cell, const std::string& sweep_file = "");
};

}  // namespace weldtwin
