#include "perception/localize/table_plane.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include <Eigen/Eigenvalues>

// PCL's templates are compiled here from its headers rather than linked from its precompiled libraries: the
// segmentation library drags in the features library, whose loading cost every process ~0.05 s.
#define PCL_NO_PRECOMPILE
#include <pcl/console/print.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include "perception/localize/stats.hpp"

namespace weldtwin {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

pcl::PointXYZ pt(const Vec3& p) {
  return pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

// A number in [0, 1) for index i: a fixed pseudo-random draw (SplitMix64's finaliser).
double unit_hash(uint64_t i) {
  uint64_t z = i + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

// A plane found by RANSAC, sized by the area its inliers spread over.
struct Found {
  Eigen::Vector4d plane;
  size_t inliers;  ///< area, in kAreaCell cells
};

constexpr double kAreaCell = 0.05;      // [m]: a box top near the scanner gathers many points on little area
constexpr double kAreaCellM2 = 0.0025;  // kAreaCell^2 [m^2]
constexpr size_t kMinPoints = 100;      // points within reach, below which no table is sought
constexpr size_t kMinInliers = 50;      // a plane's least inliers (and at least 1/50 of the points)
constexpr size_t kAreaRatio = 5;        // the table's area is at least 1/5 of the biggest plane's

}  // namespace

TablePlane find_table_plane(const std::vector<Vec3>& scan, const TablePlaneSetting& s) {
  TablePlane out;
  out.noise_m = s.min_noise_m;
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // failures are reported as values, not on stderr
  std::vector<const Vec3*> near;
  near.reserve(scan.size());
  for (const Vec3& p : scan)
    if (p.head<2>().norm() <= s.reach_radius_m) near.push_back(&p);
  if (near.size() < kMinPoints) return out;
  // The RANSAC looks at about sample_points of them, drawn at random (a fixed draw): every n-th point would
  // see the same few bearings of every scan line when n divides a line's points.
  Cloud::Ptr rest(new Cloud);
  const double keep = std::min(1.0, s.sample_points / static_cast<double>(near.size()));
  rest->reserve(static_cast<size_t>(keep * static_cast<double>(near.size())) + 1);
  for (size_t i = 0; i < near.size(); ++i)
    if (keep >= 1.0 || unit_hash(i) < keep) rest->push_back(pt(*near[i]));
  std::vector<Found> planes;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(static_cast<float>(deg2rad(s.max_tilt_deg)));
  seg.setDistanceThreshold(s.threshold_m);
  seg.setMaxIterations(s.ransac_iterations);
  const size_t total = rest->size();
  for (int k = 0; k < s.max_planes && rest->size() > kMinInliers; ++k) {
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coeff;
    seg.setInputCloud(rest);
    seg.segment(inliers, coeff);
    if (inliers.indices.size() < std::max<size_t>(kMinInliers, total / 50)) break;
    Eigen::Vector4d p(coeff.values[0], coeff.values[1], coeff.values[2], coeff.values[3]);
    if (p[2] < 0) p = -p;
    p /= p.head<3>().norm();
    // Size by the area the inliers spread over, not by their count.
    std::unordered_map<long long, char> cells;
    for (int i : inliers.indices) {
      const auto& q = (*rest)[static_cast<size_t>(i)];
      cells[static_cast<long long>(std::floor(q.x / kAreaCell)) * 100000LL +
            static_cast<long long>(std::floor(q.y / kAreaCell))] = 1;
    }
    planes.push_back({p, cells.size()});
    Cloud::Ptr next(new Cloud);
    next->reserve(rest->size() - inliers.indices.size());
    std::vector<char> drop(rest->size(), 0);
    for (int i : inliers.indices) drop[static_cast<size_t>(i)] = 1;
    for (size_t i = 0; i < rest->size(); ++i)
      if (!drop[i]) next->push_back((*rest)[i]);
    rest = next;
  }
  if (planes.empty()) return out;
  size_t biggest = 0;
  for (const Found& f : planes) biggest = std::max(biggest, f.inliers);
  const Found* table = nullptr;
  for (const Found& f : planes)
    if (f.inliers * kAreaRatio >= biggest && f.inliers * kAreaCellM2 >= s.min_area_m2 &&
        (!table || -f.plane[3] > -table->plane[3]))
      table = &f;
  if (!table) return out;
  // Least squares on the points within the band, the band narrowed to the noise as it is learnt, until the
  // plane and the noise settle. The feet of everything standing on the table (walls, clamps, the part) reach
  // into any band around it from above only; the table points next to them (raised cells: a point more than
  // the band, and at least the RANSAC's threshold, above the plane; and their neighbours) are left out. The
  // threshold keeps the table itself from raising its own cells: a real table is not flat to its noise (a
  // steel table warps by a millimetre or two), and a mask that followed the narrowing band masked more of it
  // every round, tilting the plane towards what was left (the paper's real scan: 40 k of its points in the
  // first round, 16 k by the tenth, never settling).
  Eigen::Vector4d p = table->plane;
  double band = s.threshold_m;
  double noise = s.min_noise_m;
  // Cells over the reach (a dense grid: the same cells as floor(x / cell), without hashing).
  const double rc = s.raised_cell_m;
  const long half = static_cast<long>(std::ceil(s.reach_radius_m / rc)) + 2, side = 2 * half + 1;
  std::vector<uint8_t> raised(static_cast<size_t>(side * side));
  auto cell = [&](double x, double y) {
    const long ix = static_cast<long>(std::floor(x / rc)) + half,
               iy = static_cast<long>(std::floor(y / rc)) + half;
    return static_cast<size_t>(std::clamp(iy, 0L, side - 1) * side + std::clamp(ix, 0L, side - 1));
  };
  for (int it = 0; it < s.refit_rounds; ++it) {
    std::fill(raised.begin(), raised.end(), 0);
    for (const Vec3* q : near) {
      const double r = p.head<3>().dot(*q) + p[3];
      if (r > std::max(band, s.threshold_m) && r < s.max_raised_height_m)
        for (int dx = -1; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy) raised[cell(q->x() + rc * dx, q->y() + rc * dy)] = 1;
    }
    Vec3 c = Vec3::Zero();
    std::vector<Vec3> in;
    std::vector<double> res;
    size_t in_band = 0;
    for (const Vec3* q : near) {
      const double r = p.head<3>().dot(*q) + p[3];
      if (std::abs(r) >= band) continue;
      ++in_band;
      if (!raised[cell(q->x(), q->y())]) in.push_back(*q), res.push_back(std::abs(r));
    }
    // Where things stand everywhere (clutter all over), the mask would leave too little: fall back to the
    // band.
    if (in.size() < std::max<size_t>(kMinInliers, in_band / 5)) {
      in.clear();
      res.clear();
      for (const Vec3* q : near) {
        const double r = p.head<3>().dot(*q) + p[3];
        if (std::abs(r) < band) in.push_back(*q), res.push_back(std::abs(r));
      }
    }
    if (in.size() < kMinInliers) break;
    for (const Vec3& q : in) c += q;
    c /= static_cast<double>(in.size());
    Mat3 C = Mat3::Zero();
    for (const Vec3& q : in) C += (q - c) * (q - c).transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    Vec3 n = eig.eigenvectors().col(0);
    if (n.z() < 0) n = -n;
    const Eigen::Vector4d before = p;
    const double noise_before = noise;
    p << n, -n.dot(c);
    noise = std::max(s.min_noise_m, kMadToSigma * median(res));
    band = std::max(s.band_sigmas * noise, s.min_band_m);
    // Settled: the plane moved less than settled_m anywhere within the reach, and the noise as little.
    const double moved =
        std::abs(p[3] - before[3]) + (p.head<3>() - before.head<3>()).norm() * s.reach_radius_m;
    if (moved < s.settled_m && std::abs(noise - noise_before) < s.settled_m) break;
  }
  out.found = true;
  out.plane = p;
  out.noise_m = noise;
  return out;
}

Iso3 table_frame(const Eigen::Vector4d& plane) {
  const Vec3 n = plane.head<3>();
  Mat3 R;
  R.col(2) = n;
  R.col(0) = (Vec3::UnitX() - n.x() * n).normalized();
  R.col(1) = n.cross(R.col(0));
  const Vec3 origin = -plane[3] * n;  // the plane point closest to the base origin
  return make_transform(origin, R);   // T_base_table
}

TableDiscrepancy table_discrepancy(const Eigen::Vector4d& plane, double top_z_m,
                                   const std::vector<Vec3>& points_base) {
  TableDiscrepancy out;
  const Vec3 n = plane.head<3>().normalized();
  const double d = plane[3] / plane.head<3>().norm();
  out.tilt_rad = std::atan2(n.head<2>().norm(), n.z());
  if (points_base.empty()) return out;
  // The scan's table's height above (x, y): where n.p + d = 0.
  auto height_at = [&](double x, double y) { return -(n.x() * x + n.y() * y + d) / n.z() - top_z_m; };
  Vec3 middle = Vec3::Zero();
  for (const Vec3& p : points_base) {
    const double lean = std::max(0.0, p.z() - top_z_m) * std::tan(out.tilt_rad);
    out.shift_m = std::max(out.shift_m, std::abs(height_at(p.x(), p.y())) + lean);
    middle += p;
  }
  middle /= static_cast<double>(points_base.size());
  out.height_m = height_at(middle.x(), middle.y());
  return out;
}

}  // namespace weldtwin
