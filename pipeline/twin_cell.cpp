#include "pipeline/twin_cell.hpp"

#include <utility>

#include "core/cell_robot.hpp"
#include "perception/pose_error.hpp"

namespace weldtwin {

TwinCell::TwinCell(CellSpec cell_in, const std::string& sweep_file)
    : cell(std::move(cell_in)),
      part(PartSpec::load(cell.part_spec)),
      robot(load_cell_robot(cell)),
      program(SweepProgram::load(sweep_file.empty() ? cell.sweep_program : sweep_file, robot)),
      mesh(load_mesh(part.mesh_path)),
      seam_points(part.seam_points(0.001)),
      symmetry(z_symmetry_order(mesh)) {}

}  // namespace weldtwin
