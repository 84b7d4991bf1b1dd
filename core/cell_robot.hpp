// The cell's robot: the URDF the cell names (the vendor's, as shipped) with the cell's own tooling (torch,
// TCP, LiDAR bracket) added to it as fixed links.
#pragma once

#include <string>

#include "core/cell_spec.hpp"
#include "core/robot_model.hpp"

namespace weldtwin {

/// The URDF text of the cell's robot: the robot file with one `<link>` and one fixed `<joint>` per tooling
/// link added before its `</robot>`. Throws InputError naming the cell for tooling that does not fit the
/// robot (an unknown parent, a link or joint name the robot already has).
std::string cell_robot_urdf(const CellSpec& cell);

/// The cell's robot, loaded from cell_robot_urdf() (package:// meshes through the cell's package folders).
RobotModel load_cell_robot(const CellSpec& cell);

}  // namespace weldtwin
