// Point cloud files: PCD (PCL's format: ascii, binary, binary_compressed) and PLY, read and written by
// weldtwin itself (see cloud_io.cpp for why not through PCL's I/O module).
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// Writes x y z (float) as binary PCD, or ascii when `ascii` is set. With `viewpoints` (one per point: where
/// the sensor was when it saw it), the fields are PCL's PointWithViewpoint: x y z vp_x vp_y vp_z. Throws
/// std::runtime_error on failure.
void write_pcd(const std::string& path, const std::vector<Vec3>& points, bool ascii = false,
               const std::vector<Vec3>* viewpoints = nullptr);

/// Reads x y z from a PCD or PLY file (by extension). Drops non-finite points and reports how many. If
/// `viewpoints` is given, it receives vp_x vp_y vp_z per point kept when the file has them, else it is left
/// empty. Throws InputError naming the file for a missing, empty, malformed or truncated file.
std::vector<Vec3> read_cloud(const std::string& path, size_t* dropped_non_finite = nullptr,
                             std::vector<Vec3>* viewpoints = nullptr);

/// A PLY mesh (ascii, binary of either endian): every vertex, and the faces' vertex indices (polygons as fans
/// of triangles), each checked against the vertices. Throws InputError naming the file.
std::vector<Vec3> read_ply_mesh(const std::string& path, std::vector<Eigen::Vector3i>& faces);

}  // namespace weldtwin
