#include "perception/cloud_io.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <cmath>
#include <filesystem>

#include "core/error.hpp"

namespace weldtwin {
namespace {

template <typename PointT>
void write_cloud(const std::string& path, const pcl::PointCloud<PointT>& cloud, bool ascii) {
  pcl::PCDWriter writer;
  const int rc = cloud.empty() ? writer.writeASCII(path, cloud) : writer.write(path, cloud, !ascii);
  if (rc != 0) throw std::runtime_error(path + ": cannot write the point cloud");
}

bool finite(const Vec3& p) {
  return p.allFinite();
}

}  // namespace

void write_pcd(const std::string& path, const std::vector<Vec3>& points, bool ascii,
               const std::vector<Vec3>* viewpoints) {
  if (viewpoints && viewpoints->size() != points.size())
    throw std::invalid_argument(path + ": one viewpoint per point is needed");
  auto f = [](double v) { return static_cast<float>(v); };
  if (viewpoints) {
    pcl::PointCloud<pcl::PointWithViewpoint> cloud;
    cloud.resize(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      const Vec3 &p = points[i], &v = (*viewpoints)[i];
      cloud[i] = pcl::PointWithViewpoint(f(p.x()), f(p.y()), f(p.z()), f(v.x()), f(v.y()), f(v.z()));
    }
    cloud.width = static_cast<uint32_t>(points.size());
    cloud.height = 1;
    write_cloud(path, cloud, ascii);
    return;
  }
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    cloud[i] = pcl::PointXYZ(f(points[i].x()), f(points[i].y()), f(points[i].z()));
  cloud.width = static_cast<uint32_t>(points.size());
  cloud.height = 1;
  write_cloud(path, cloud, ascii);
}

std::vector<Vec3> read_cloud(const std::string& path, size_t* dropped_non_finite,
                             std::vector<Vec3>* viewpoints) {
  if (!std::filesystem::is_regular_file(path)) throw input_error(path, "no such file");
  if (std::filesystem::file_size(path) == 0) throw input_error(path, "empty file");
  const std::string ext = std::filesystem::path(path).extension().string();
  pcl::PCLPointCloud2 blob;
  int rc = -1;
  if (ext == ".pcd" || ext == ".PCD") {
    pcl::PCDReader reader;
    rc = reader.read(path, blob);
  } else if (ext == ".ply" || ext == ".PLY") {
    pcl::PLYReader reader;
    rc = reader.read(path, blob);
  } else {
    throw input_error(path, "unknown cloud format '" + ext + "' (expected .pcd or .ply)");
  }
  if (rc < 0) throw input_error(path, "malformed or truncated point cloud");
  if (pcl::getFieldIndex(blob, "x") < 0 || pcl::getFieldIndex(blob, "y") < 0 ||
      pcl::getFieldIndex(blob, "z") < 0)
    throw input_error(path, "the cloud has no x, y, z fields");
  const bool with_vp = viewpoints && pcl::getFieldIndex(blob, "vp_x") >= 0 &&
                       pcl::getFieldIndex(blob, "vp_y") >= 0 && pcl::getFieldIndex(blob, "vp_z") >= 0;
  if (viewpoints) viewpoints->clear();
  std::vector<Vec3> out;
  size_t dropped = 0;
  if (with_vp) {
    pcl::PointCloud<pcl::PointWithViewpoint> cloud;
    pcl::fromPCLPointCloud2(blob, cloud);
    out.reserve(cloud.size());
    viewpoints->reserve(cloud.size());
    for (const auto& p : cloud) {
      const Vec3 x(p.x, p.y, p.z), v(p.vp_x, p.vp_y, p.vp_z);
      if (!finite(x) || !finite(v)) {
        ++dropped;
        continue;
      }
      out.push_back(x);
      viewpoints->push_back(v);
    }
  } else {
    pcl::PointCloud<pcl::PointXYZ> cloud;
    pcl::fromPCLPointCloud2(blob, cloud);
    out.reserve(cloud.size());
    for (const auto& p : cloud) {
      const Vec3 x(p.x, p.y, p.z);
      if (finite(x)) {
        out.push_back(x);
      } else {
        ++dropped;
      }
    }
  }
  if (dropped_non_finite) *dropped_non_finite = dropped;
  return out;
}

}  // namespace weldtwin
