#include "perception/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <cmath>
#include <filesystem>

#include "core/error.hpp"

namespace weldtwin {

void write_pcd(const std::string& path, const std::vector<Vec3>& points, bool ascii) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    cloud[i] = pcl::PointXYZ(static_cast<float>(points[i].x()), static_cast<float>(points[i].y()),
                             static_cast<float>(points[i].z()));
  cloud.width = static_cast<uint32_t>(points.size());
  cloud.height = 1;
  cloud.is_dense = true;
  pcl::PCDWriter writer;
  const int rc = points.empty() ? writer.writeASCII(path, cloud) : writer.write(path, cloud, !ascii);
  if (rc != 0) throw std::runtime_error(path + ": cannot write the point cloud");
}

std::vector<Vec3> read_cloud(const std::string& path, size_t* dropped_non_finite) {
  if (!std::filesystem::is_regular_file(path)) throw input_error(path, "no such file");
  if (std::filesystem::file_size(path) == 0) throw input_error(path, "empty file");
  const std::string ext = std::filesystem::path(path).extension().string();
  pcl::PointCloud<pcl::PointXYZ> cloud;
  int rc = -1;
  if (ext == ".pcd" || ext == ".PCD") {
    pcl::PCDReader reader;
    rc = reader.read(path, cloud);
  } else if (ext == ".ply" || ext == ".PLY") {
    pcl::PLYReader reader;
    rc = reader.read(path, cloud);
  } else {
    throw input_error(path, "unknown cloud format '" + ext + "' (expected .pcd or .ply)");
  }
  if (rc < 0) throw input_error(path, "malformed or truncated point cloud");
  std::vector<Vec3> out;
  out.reserve(cloud.size());
  size_t dropped = 0;
  for (const auto& p : cloud) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      out.emplace_back(p.x, p.y, p.z);
    } else {
      ++dropped;
    }
  }
  if (dropped_non_finite) *dropped_non_finite = dropped;
  return out;
}

}  // namespace weldtwin
