// The weldability map as a picture a person reads at a glance: the table seen from above with the robot at
// the bottom edge, each grid position coloured by the share of yaws at which the part welds (green), or by
// why none does (red: the arm collides; orange: out of reach; grey: no room for the part and its clamps);
// outlines mark placements (where the part was found, where to put it).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "sim/renderer.hpp"  // Image
#include "sim/weldability.hpp"

namespace weldtwin {

struct MapMark {
  std::vector<Eigen::Vector2d> outline_base;  ///< closed polygon on the table, base frame [m]
  std::array<uint8_t, 3> rgb{0, 0, 0};
};

/// The part's footprint at (x, y, yaw) as a mark.
MapMark footprint_mark(const PartSpec& part, double x_m, double y_m, double yaw_rad,
                       std::array<uint8_t, 3> rgb);

Image weldability_picture(const WeldabilityMap& map, const std::vector<MapMark>& marks = {},
                          int pixels_per_cm = 6);

}  // namespace weldtwin
