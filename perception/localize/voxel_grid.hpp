// PCL's voxel grid: the centroid of the points in each occupied cube.
#pragma once

#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// Centroid of the points in each occupied cube of edge `leaf_m` (PCL's VoxelGrid, in its order).
std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double leaf_m);

}  // namespace weldtwin
