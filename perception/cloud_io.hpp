// Point cloud files through PCL (PCD ascii/binary, PLY). PCL's headers stay inside cloud_io.cpp.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// Writes x y z (float) as binary PCD, or ascii when `ascii` is set. Throws std::runtime_error on failure.
void write_pcd(const std::string& path, const std::vector<Vec3>& points, bool ascii = false);

/// Reads x y z from a PCD or PLY file (by extension). Drops non-finite points and reports how many.
/// Throws InputError naming the file for a missing, empty, malformed or truncated file.
std::vector<Vec3> read_cloud(const std::string& path, size_t* dropped_non_finite = nullptr);

}  // namespace weldtwin
