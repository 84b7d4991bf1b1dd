#include "perception/localize/voxel_grid.hpp"

// PCL's templates from its headers (see table_plane.cpp).
#define PCL_NO_PRECOMPILE
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>

namespace weldtwin {

std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double leaf) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr in(new pcl::PointCloud<pcl::PointXYZ>),
      out(new pcl::PointCloud<pcl::PointXYZ>);
  in->reserve(points.size());
  for (const Vec3& p : points)
    in->push_back(
        pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(in);
  const float l = static_cast<float>(leaf);
  grid.setLeafSize(l, l, l);
  grid.filter(*out);
  std::vector<Vec3> v;
  v.reserve(out->size());
  for (const auto& p : *out) v.emplace_back(p.x, p.y, p.z);
  return v;
}

}  // namespace weldtwin
