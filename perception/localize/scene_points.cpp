#include "perception/localize/scene_points.hpp"

#include <algorithm>
#include <cmath>

#include "perception/localize/table_plane.hpp"
#include "perception/localize/voxel_grid.hpp"

namespace weldtwin {
namespace {

constexpr size_t kMinObjectPoints = 50;        // fewer points above the table: nothing stands on it
constexpr uint16_t kMaxCellCount = 60000;      // a cell's count stops here (16 bits)
constexpr size_t kViewpointProbeStride = 97;   // viewpoints looked at to judge them
constexpr double kBelowTableSigmas = 3.0;      // points this far below the plane are not near it
constexpr double kOutlineTopCuts = 3.0;        // outline samples of parts at most this many height cuts high
constexpr double kMinSmoothingRadius = 0.004;  // [m]

}  // namespace

ScenePoints scene_points(const std::vector<Vec3>& scan_base, const std::vector<Vec3>& viewpoints_base,
                         const Eigen::Vector4d& plane, const NoiseLimits& limits, double part_height,
                         double reach_radius_m, const ScenePointsSetting& s) {
  ScenePoints out;
  out.limits = limits;
  const double noise = limits.noise_m;
  out.T_base_table = table_frame(plane);
  out.T_table_base = out.T_base_table.inverse();
  const Iso3& T_table_base = out.T_table_base;

  // Object points above the table (table frame), and the points near the table by cell.
  std::vector<Vec3> above;
  out.outline_max_top = kOutlineTopCuts * limits.height_cut_m;
  out.low.shape(Eigen::Vector2d::Constant(-reach_radius_m), Eigen::Vector2d::Constant(reach_radius_m),
                s.low_cell_m);
  out.low_sum = zeroed_slots<float>(out.low.cells());
  out.low_count = zeroed_slots<uint16_t>(out.low.cells());
  const double low_top = out.outline_max_top + kBelowTableSigmas * noise;
  // With the sensor's position for every point, the fine refinement casts the rays themselves against the
  // model (a voxel's centroid would mix the two sides of a thin wall, and a point's own position, thrown by
  // the noise, cannot say which side it is on).
  // Viewpoints that cannot be a LiDAR looking down at the table (all zero, as some tools fill PCL's
  // PointWithViewpoint) are not used: a ray cast from the wrong place would match points with wrong faces.
  bool rays = viewpoints_base.size() == scan_base.size() && !scan_base.empty();
  if (rays) {
    size_t above_table = 0, looked = 0;
    for (size_t i = 0; i < viewpoints_base.size(); i += kViewpointProbeStride, ++looked)
      above_table += (T_table_base * viewpoints_base[i]).z() > s.min_viewpoint_height_m;
    rays = above_table >= s.viewpoints_above_share * static_cast<double>(looked);
  }
  const double top = part_height + s.above_part_m;
  for (size_t i = 0; i < scan_base.size(); ++i) {
    const Vec3& p = scan_base[i];
    const double rxy = p.head<2>().norm();
    if (rxy < s.base_keepout_m || rxy > reach_radius_m) continue;
    const Vec3 q = T_table_base * p;
    if (rays && q.z() > -kBelowTableSigmas * noise && q.z() < top)
      out.ray_points.push_back(static_cast<uint32_t>(i));
    if (q.z() > -kBelowTableSigmas * noise && q.z() < low_top) {
      const long cell = out.low.index(q.x(), q.y());
      if (cell >= 0 && out.low_count[static_cast<size_t>(cell)] < kMaxCellCount) {
        out.low_sum[static_cast<size_t>(cell)] += static_cast<float>(q.z());
        ++out.low_count[static_cast<size_t>(cell)];
      }
    }
    if (q.z() < s.min_height_m || q.z() > top) continue;
    above.push_back(q);
  }
  if (above.size() < kMinObjectPoints) {
    out.reason = "nothing stands on the table";
    return out;
  }
  out.objects = voxel_centroids(above, s.voxel_m);
  if (out.objects.size() < kMinObjectPoints) {
    out.reason = "nothing stands on the table";
    return out;
  }
  out.tree = PointTree(out.objects);

  // The points ICP uses (high enough to be told from the table), each with its neighbourhood's centroid.
  {
    const std::vector<Vec3>& scan = out.tree.points();
    std::vector<uint32_t> idx;
    std::vector<double> d2;
    const double r2 = std::pow(std::max(kMinSmoothingRadius, s.smoothing_radius_sigmas * noise), 2);
    for (const Vec3& q : scan) {
      if (q.z() < limits.height_cut_m) continue;
      Vec3 mean = Vec3::Zero();
      int n = 0;
      if (out.tree.knn(q, static_cast<size_t>(s.smoothing_neighbours), idx, d2) > 0)
        for (size_t j = 0; j < idx.size(); ++j)
          if (d2[j] <= r2) mean += scan[idx[j]], ++n;
      out.icp_points.push_back({q, n ? Vec3(mean / n) : q});
    }
  }
  out.ok = true;
  return out;
}

}  // namespace weldtwin
