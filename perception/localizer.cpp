#include "perception/localizer.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

// PCL's templates are compiled here from its headers rather than linked from its precompiled libraries: the
// segmentation library drags in the features library, whose loading cost every process ~0.05 s.
#define PCL_NO_PRECOMPILE
#include <pcl/console/print.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include "perception/mesh_rays.hpp"

#include <nanoflann.hpp>

namespace weldtwin {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Clock = std::chrono::steady_clock;

pcl::PointXYZ pt(const Vec3& p) {
  return pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

Cloud::Ptr to_cloud(const std::vector<Vec3>& points) {
  Cloud::Ptr c(new Cloud);
  c->reserve(points.size());
  for (const Vec3& p : points) c->push_back(pt(p));
  return c;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Nearest neighbours among fixed points: nanoflann's kd-tree. A query is a plain function call (PCL's FLANN
// wrapper opens an OpenMP region and allocates for every single-point query, which made those queries most
// of a localization's time).
class PointTree {
 public:
  explicit PointTree(std::vector<Vec3> points = {}) : data_(std::make_unique<Data>()) {
    data_->pts = std::move(points);
    index_ = std::make_unique<Index>(3, *data_, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  }
  /// The k nearest points, nearest first: indices and squared distances. Returns how many.
  size_t knn(const Vec3& q, size_t k, std::vector<uint32_t>& idx, std::vector<double>& d2) const {
    idx.resize(k);
    d2.resize(k);
    const size_t n = data_->pts.empty() ? 0 : index_->knnSearch(q.data(), k, idx.data(), d2.data());
    idx.resize(n);
    d2.resize(n);
    return n;
  }
  /// The nearest point's index (-1 if there are none) and its squared distance.
  int nearest(const Vec3& q, double& d2) const {
    if (data_->pts.empty()) return -1;
    uint32_t i = 0;
    index_->knnSearch(q.data(), 1, &i, &d2);
    return static_cast<int>(i);
  }

 private:
  struct Data {
    std::vector<Vec3> pts;
    size_t kdtree_get_point_count() const { return pts.size(); }
    double kdtree_get_pt(size_t i, size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Data>, Data, 3>;
  std::unique_ptr<Data> data_;  // the index refers to it: it must not move
  std::unique_ptr<Index> index_;
};

// Runs fn(0..n-1) on up to `threads` threads (0: all cores).
template <typename Fn>
void parallel_for(size_t n, int threads, Fn fn) {
  const size_t workers = std::min<size_t>(
      n, threads > 0 ? static_cast<size_t>(threads) : std::max(1u, std::thread::hardware_concurrency()));
  if (workers <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  for (size_t w = 0; w < workers; ++w)
    pool.emplace_back([&] {
      for (size_t i; (i = next++) < n;) fn(i);
    });
  for (auto& t : pool) t.join();
}

// ---------------------------------------------------------------------------------------------- the table

// The table: cascaded RANSAC for near-horizontal planes on an even thinning of the scan; of the big ones, the
// highest (the floor is bigger but lower). Refined by least squares on the full-resolution points near it;
// the spread of those points about the plane gives the range noise. Returns false if there is none.
}  // namespace

bool find_table_plane(const std::vector<Vec3>& scan, const LocalizeSetting& s, Eigen::Vector4d& plane,
                      double& noise) {
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // failures are reported as values, not on stderr
  std::vector<const Vec3*> near;
  near.reserve(scan.size());
  for (const Vec3& p : scan)
    if (p.head<2>().norm() <= s.reach_radius_m) near.push_back(&p);
  if (near.size() < 100) return false;
  Cloud::Ptr rest(new Cloud);
  const size_t stride = std::max<size_t>(1, near.size() / static_cast<size_t>(s.table_sample_points));
  for (size_t i = 0; i < near.size(); i += stride) rest->push_back(pt(*near[i]));
  struct Found {
    Eigen::Vector4d plane;
    size_t inliers;  ///< area, in 5 cm cells
  };
  std::vector<Found> planes;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(static_cast<float>(deg2rad(s.table_max_tilt_deg)));
  seg.setDistanceThreshold(s.table_threshold_m);
  seg.setMaxIterations(300);
  const size_t total = rest->size();
  for (int k = 0; k < 4 && rest->size() > 50; ++k) {
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coeff;
    seg.setInputCloud(rest);
    seg.segment(inliers, coeff);
    if (inliers.indices.size() < std::max<size_t>(50, total / 50)) break;
    Eigen::Vector4d p(coeff.values[0], coeff.values[1], coeff.values[2], coeff.values[3]);
    if (p[2] < 0) p = -p;
    p /= p.head<3>().norm();
    // Size by the area the inliers spread over (5 cm cells), not by their count: a box top near the scanner
    // gathers many points on little area.
    std::unordered_map<long long, char> cells;
    for (int i : inliers.indices) {
      const auto& q = (*rest)[static_cast<size_t>(i)];
      cells[static_cast<long long>(std::floor(q.x / 0.05)) * 100000LL +
            static_cast<long long>(std::floor(q.y / 0.05))] = 1;
    }
    planes.push_back({p, cells.size()});
    Cloud::Ptr next(new Cloud);
    std::vector<char> drop(rest->size(), 0);
    for (int i : inliers.indices) drop[static_cast<size_t>(i)] = 1;
    for (size_t i = 0; i < rest->size(); ++i)
      if (!drop[i]) next->push_back((*rest)[i]);
    rest = next;
  }
  if (planes.empty()) return false;
  size_t biggest = 0;
  for (const Found& f : planes) biggest = std::max(biggest, f.inliers);
  const Found* table = nullptr;
  for (const Found& f : planes)
    if (f.inliers * 5 >= biggest && f.inliers * 0.0025 >= s.min_table_area_m2 &&
        (!table || -f.plane[3] > -table->plane[3]))
      table = &f;
  if (!table) return false;
  // Least squares on the points within the band, the band narrowed to 3 sigma of the noise as it is learnt.
  // The feet of everything standing on the table (walls, clamps, the part) reach into any band around it
  // from above only; the table points next to them (1 cm cells, and their neighbours) are left out.
  Eigen::Vector4d p = table->plane;
  double band = s.table_threshold_m;
  // 1 cm cells over the reach (a dense grid: the same cells as floor(x / 1 cm), without hashing).
  const long half = static_cast<long>(std::ceil(s.reach_radius_m / 0.01)) + 2, side = 2 * half + 1;
  std::vector<uint8_t> raised(static_cast<size_t>(side * side));
  auto cell = [&](double x, double y) {
    const long ix = static_cast<long>(std::floor(x / 0.01)) + half,
               iy = static_cast<long>(std::floor(y / 0.01)) + half;
    return static_cast<size_t>(std::clamp(iy, 0L, side - 1) * side + std::clamp(ix, 0L, side - 1));
  };
  for (int it = 0; it < 4; ++it) {
    std::fill(raised.begin(), raised.end(), 0);
    for (const Vec3* q : near) {
      const double r = p.head<3>().dot(*q) + p[3];
      if (r > band && r < 0.5)
        for (int dx = -1; dx <= 1; ++dx)
          for (int dy = -1; dy <= 1; ++dy) raised[cell(q->x() + 0.01 * dx, q->y() + 0.01 * dy)] = 1;
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
    if (in.size() < std::max<size_t>(50, in_band / 5)) {
      in.clear();
      res.clear();
      for (const Vec3* q : near) {
        const double r = p.head<3>().dot(*q) + p[3];
        if (std::abs(r) < band) in.push_back(*q), res.push_back(std::abs(r));
      }
    }
    if (in.size() < 50) break;
    for (const Vec3& q : in) c += q;
    c /= static_cast<double>(in.size());
    Mat3 C = Mat3::Zero();
    for (const Vec3& q : in) C += (q - c) * (q - c).transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    Vec3 n = eig.eigenvectors().col(0);
    if (n.z() < 0) n = -n;
    p << n, -n.dot(c);
    noise = std::max(s.min_noise_m, 1.4826 * median(res));
    band = std::max(3.5 * noise, 0.002);
  }
  plane = p;
  return true;
}

std::vector<Vec3> voxel_centroids(const std::vector<Vec3>& points, double leaf) {
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(to_cloud(points));
  const float l = static_cast<float>(leaf);
  grid.setLeafSize(l, l, l);
  grid.filter(*out);
  std::vector<Vec3> v;
  v.reserve(out->size());
  for (const auto& p : *out) v.emplace_back(p.x, p.y, p.z);
  return v;
}

Iso3 planar_rigid_fit(const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
  const size_t n = std::min(from.size(), to.size());
  if (n == 0) return Iso3::Identity();
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < n; ++i) ca += from[i].head<2>(), cb += to[i].head<2>();
  ca /= static_cast<double>(n);
  cb /= static_cast<double>(n);
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < n; ++i) H += (from[i].head<2>() - ca) * (to[i].head<2>() - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix2d R = svd.matrixV() * svd.matrixU().transpose();
  if (R.determinant() < 0) {  // a reflection is no motion: flip the weaker axis
    Eigen::Matrix2d V = svd.matrixV();
    V.col(1) *= -1;
    R = V * svd.matrixU().transpose();
  }
  const Eigen::Vector2d t = cb - R * ca;
  return planar_pose(t.x(), t.y(), 0.0, std::atan2(R(1, 0), R(0, 0)));
}

namespace {

// A rigid transform from the table frame: z along the plane normal, origin under the base origin.
Iso3 table_frame(const Eigen::Vector4d& plane) {
  const Vec3 n = plane.head<3>();
  Mat3 R;
  R.col(2) = n;
  R.col(0) = (Vec3::UnitX() - n.x() * n).normalized();
  R.col(1) = n.cross(R.col(0));
  const Vec3 origin = -plane[3] * n;  // the plane point closest to the base origin
  return make_transform(origin, R);   // T_base_table
}

// ---------------------------------------------------------------------------------------------- the model

// A 2D occupancy grid in some frame: cells of `cell` metres from `origin`.
struct Grid2 {
  double cell = 0.002;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  int nx = 0, ny = 0;
  std::vector<uint8_t> on;
  std::vector<float> value;  ///< per cell: the model's top height (footprint), the lowest point (table)

  void reset(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double c) {
    cell = c;
    origin = lo;
    nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / c)) + 1;
    ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / c)) + 1;
    on.assign(static_cast<size_t>(nx) * static_cast<size_t>(ny), 0);
    value.assign(on.size(), std::numeric_limits<float>::infinity());
  }
  long index(double x, double y) const {
    const long ix = static_cast<long>(std::floor((x - origin.x()) / cell)),
               iy = static_cast<long>(std::floor((y - origin.y()) / cell));
    if (ix < 0 || iy < 0 || ix >= nx || iy >= ny) return -1;
    return iy * nx + ix;
  }
  Eigen::Vector2d centre(long i) const {
    return origin +
           cell * Eigen::Vector2d(static_cast<double>(i % nx) + 0.5, static_cast<double>(i / nx) + 0.5);
  }
};

struct Model {
  std::vector<Vec3> pts, nrm;       // part frame, resting on z = 0; every face but the underside
  std::vector<uint8_t> visible;     // seen from outside (a scanner above the table can see it at all)
  std::vector<uint8_t> view_score;  // how many of the test directions see it (more: seen more often)
  std::vector<float> half_thickness, edge_distance;
  PointTree tree;
  std::unique_ptr<MeshRays> rays;             // the mesh itself, resting on z = 0 (part frame)
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // bounding box of the samples
  double radius = 0.0, height = 0.0;
  std::vector<std::vector<int>> walls_by_height;  // visible wall samples (every third) per height bin
  Grid2 footprint;                                // where the part rests on the table, eroded
  struct OutlineSample {
    Eigen::Vector2d at, out;  // on the footprint's outline, and the outward normal there
    double top = 0.0;         // height of the part just inside
  };
  std::vector<OutlineSample> outline;  // every 1 mm, away from the outline's corners

  // Nearest sample by a lazily filled 1 mm grid over the box (+ margin): ICP asks about the same places
  // again and again, so most lookups are one array read.
  double cache_cell = 0.001, cache_margin = 0.015;
  Vec3 cache_origin = Vec3::Zero();
  int cx = 0, cy = 0, cz = 0;
  std::vector<int> cache;

  // Safe to call from several threads: a slot is filled with the same answer by whoever gets there first.
  int nearest(const Vec3& p) {
    if (!p.allFinite()) return -1;
    const long ix = static_cast<long>((p.x() - cache_origin.x()) / cache_cell),
               iy = static_cast<long>((p.y() - cache_origin.y()) / cache_cell),
               iz = static_cast<long>((p.z() - cache_origin.z()) / cache_cell);
    if (p.x() < cache_origin.x() || p.y() < cache_origin.y() || p.z() < cache_origin.z() || ix >= cx ||
        iy >= cy || iz >= cz)
      return -1;
    int* slot = &cache[(static_cast<size_t>(iz) * static_cast<size_t>(cy) + static_cast<size_t>(iy)) *
                           static_cast<size_t>(cx) +
                       static_cast<size_t>(ix)];
    int known = __atomic_load_n(slot, __ATOMIC_RELAXED);
    if (known == -2) {
      const Vec3 c =
          cache_origin + cache_cell * Vec3(static_cast<double>(ix) + 0.5, static_cast<double>(iy) + 0.5,
                                           static_cast<double>(iz) + 0.5);
      double d2 = 0.0;
      known = tree.nearest(c, d2);
      __atomic_store_n(slot, known, __ATOMIC_RELAXED);
    }
    return known;
  }
};

constexpr double kHeightBin = 0.002;
constexpr double kMinViewpointHeight = 0.05;  // a LiDAR scanning the table looks from above it
constexpr double kRayWindow = 0.02;  // a ray meeting the model this much before or beyond its range meets
                                     // something else

// Feature edges of the mesh (where the faces meet at more than 30 deg, or a face has no neighbour), except
// along the underside resting on the table, as points 1 mm apart.
std::vector<Vec3> feature_edge_points(const Mesh& mesh, double min_z) {
  // Vertices by position (a mesh file may repeat them per face), to 1 micrometre.
  std::map<std::array<long long, 3>, int> ids;
  std::vector<int> id(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& v = mesh.vertices[i];
    const std::array<long long, 3> k{std::llround(v.x() * 1e6), std::llround(v.y() * 1e6),
                                     std::llround(v.z() * 1e6)};
    id[i] = ids.emplace(k, static_cast<int>(ids.size())).first->second;
  }
  std::map<std::pair<int, int>, std::vector<Vec3>> edges;
  std::map<std::pair<int, int>, std::pair<size_t, size_t>> ends;
  for (const auto& f : mesh.faces) {
    const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
               &c = mesh.vertices[static_cast<size_t>(f[2])];
    const Vec3 n = (b - a).cross(c - a);
    if (n.norm() < 1e-14) continue;
    for (int k = 0; k < 3; ++k) {
      const size_t vi = static_cast<size_t>(f[k]), vj = static_cast<size_t>(f[(k + 1) % 3]);
      const std::pair<int, int> e{std::min(id[vi], id[vj]), std::max(id[vi], id[vj])};
      edges[e].push_back(n.normalized());
      ends[e] = {vi, vj};
    }
  }
  std::vector<Vec3> out;
  for (const auto& [e, normals] : edges) {
    const bool sharp = normals.size() != 2 || normals[0].dot(normals[1]) < std::cos(deg2rad(30.0));
    if (!sharp) continue;
    const Vec3 &a = mesh.vertices[ends[e].first], &b = mesh.vertices[ends[e].second];
    if (a.z() - min_z < 1e-4 && b.z() - min_z < 1e-4) continue;
    const int n = std::max(1, static_cast<int>((b - a).norm() / 0.001));
    for (int k = 0; k <= n; ++k) out.push_back(a + (b - a) * (static_cast<double>(k) / n));
  }
  return out;
}

// Marks the cells of `grid` whose centres lie inside the triangle abc (x, y only).
void fill_triangle(Grid2& grid, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double x0 = std::min({a.x(), b.x(), c.x()}), x1 = std::max({a.x(), b.x(), c.x()});
  const double y0 = std::min({a.y(), b.y(), c.y()}), y1 = std::max({a.y(), b.y(), c.y()});
  auto side = [](const Vec3& p, const Vec3& q, double x, double y) {
    return (q.x() - p.x()) * (y - p.y()) - (q.y() - p.y()) * (x - p.x());
  };
  for (double y = grid.origin.y() + grid.cell * (std::floor((y0 - grid.origin.y()) / grid.cell) + 0.5);
       y <= y1; y += grid.cell)
    for (double x = grid.origin.x() + grid.cell * (std::floor((x0 - grid.origin.x()) / grid.cell) + 0.5);
         x <= x1; x += grid.cell) {
      const double s0 = side(a, b, x, y), s1 = side(b, c, x, y), s2 = side(c, a, x, y);
      if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) {
        const long i = grid.index(x, y);
        if (i >= 0) grid.on[static_cast<size_t>(i)] = 1;
      }
    }
}

void build_model(const Mesh& mesh, double min_z, const LocalizeSetting& s, Model& model) {
  Mesh rest = mesh;
  for (Vec3& v : rest.vertices) v.z() -= min_z;
  orient_outward(rest);  // a mesh file's winding is not to be trusted
  const SurfaceSamples all = sample_surface(rest, s.model_spacing_m, -0.7);
  model.rays = std::make_unique<MeshRays>(rest);
  const MeshRays& rays = *model.rays;
  model.pts = all.points;
  model.nrm = all.normals;
  const size_t n = model.pts.size();
  model.visible.resize(n);
  model.view_score.resize(n);
  model.half_thickness.resize(n);
  model.lo = Vec3::Constant(1e9);
  model.hi = Vec3::Constant(-1e9);
  constexpr size_t kChunk = 512;
  parallel_for((n + kChunk - 1) / kChunk, s.threads, [&](size_t chunk) {
    for (size_t k = chunk * kChunk; k < std::min(n, (chunk + 1) * kChunk); ++k) {
      const Vec3& p = model.pts[k];
      const Vec3& nn = model.nrm[k];
      model.view_score[k] = static_cast<uint8_t>(view_directions(rays, p, nn));
      model.visible[k] = model.view_score[k] > 0;
      // Half the distance to the next surface behind the face or facing it: a residual beyond that may
      // belong to the other surface, so trimming there keeps thin walls unbiased.
      const double behind = rays.hit(p, -nn, 1e-5, 0.05), front = rays.hit(p, nn, 1e-5, 0.05);
      model.half_thickness[k] = static_cast<float>(0.5 * std::min({behind, front, 0.1}));
    }
  });
  for (size_t k = 0; k < n; ++k) {
    const Vec3& p = model.pts[k];
    model.lo = model.lo.cwiseMin(p);
    model.hi = model.hi.cwiseMax(p);
    model.radius = std::max(model.radius, p.head<2>().norm());
  }
  model.height = model.hi.z();
  model.tree = PointTree(model.pts);

  // Distance of every sample to the nearest feature edge.
  model.edge_distance.assign(n, 1.0f);
  const std::vector<Vec3> edge_pts = feature_edge_points(rest, 0.0);
  if (!edge_pts.empty()) {
    const PointTree edge_tree(edge_pts);
    parallel_for((n + kChunk - 1) / kChunk, s.threads, [&](size_t chunk) {
      double d2 = 0.0;
      for (size_t k = chunk * kChunk; k < std::min(n, (chunk + 1) * kChunk); ++k)
        if (edge_tree.nearest(model.pts[k], d2) >= 0)
          model.edge_distance[k] = static_cast<float>(std::sqrt(d2));
    });
  }

  // Wall samples by height for the Hough vote.
  model.walls_by_height.assign(static_cast<size_t>(model.height / kHeightBin) + 2, {});
  for (size_t k = 0; k < n; k += 3)
    if (model.visible[k] && std::abs(model.nrm[k].z()) < 0.5)
      model.walls_by_height[static_cast<size_t>(std::max(0.0, model.pts[k].z()) / kHeightBin)].push_back(
          static_cast<int>(k));

  // Footprint: the underside faces resting on the table.
  model.footprint.reset(model.lo.head<2>() - Eigen::Vector2d::Constant(0.004),
                        model.hi.head<2>() + Eigen::Vector2d::Constant(0.004), 0.002);
  for (const auto& f : rest.faces) {
    const Vec3 &a = rest.vertices[static_cast<size_t>(f[0])], &b = rest.vertices[static_cast<size_t>(f[1])],
               &c = rest.vertices[static_cast<size_t>(f[2])];
    const Vec3 nn = (b - a).cross(c - a);
    if (nn.norm() < 1e-14 || nn.normalized().z() > -0.9 || std::max({a.z(), b.z(), c.z()}) > 1e-3) continue;
    fill_triangle(model.footprint, a, b, c);
  }
  // The footprint's outline: edges of the underside used by one underside face only, away from corners.
  {
    std::map<std::array<long long, 4>, std::pair<int, Eigen::Vector2d>> edges;  // edge -> uses, outward
    auto key2 = [](const Vec3& v) {
      return std::array<long long, 2>{std::llround(v.x() * 1e6), std::llround(v.y() * 1e6)};
    };
    std::map<std::array<long long, 4>, std::pair<Vec3, Vec3>> ends;
    for (const auto& f : rest.faces) {
      const Vec3 v[3] = {rest.vertices[static_cast<size_t>(f[0])], rest.vertices[static_cast<size_t>(f[1])],
                         rest.vertices[static_cast<size_t>(f[2])]};
      const Vec3 nn = (v[1] - v[0]).cross(v[2] - v[0]);
      if (nn.norm() < 1e-14 || nn.normalized().z() > -0.9 || std::max({v[0].z(), v[1].z(), v[2].z()}) > 1e-3)
        continue;
      for (int k = 0; k < 3; ++k) {
        const Vec3 &a = v[k], &b = v[(k + 1) % 3], &o = v[(k + 2) % 3];
        auto ka = key2(a), kb = key2(b);
        if (kb < ka) std::swap(ka, kb);
        const std::array<long long, 4> key{ka[0], ka[1], kb[0], kb[1]};
        Eigen::Vector2d e = (b - a).head<2>(), out(e.y(), -e.x());
        out.normalize();
        if (out.dot((o - a).head<2>()) > 0) out = -out;
        auto& entry = edges[key];
        ++entry.first;
        entry.second = out;
        ends[key] = {a, b};
      }
    }
    for (const auto& [key, entry] : edges) {
      if (entry.first != 1) continue;
      const Vec3 &a = ends[key].first, &b = ends[key].second;
      const double len = (b - a).head<2>().norm();
      for (double t = 0.004; t <= len - 0.004; t += 0.001) {
        const Eigen::Vector2d at = a.head<2>() + (b - a).head<2>() * (t / len);
        const Eigen::Vector2d inside = at - 0.003 * entry.second;
        const double h = rays.hit(Vec3(inside.x(), inside.y(), model.height + 0.01), -Vec3::UnitZ(), 0.0);
        if (!std::isfinite(h)) continue;
        model.outline.push_back({at, entry.second, model.height + 0.01 - h});
      }
    }
  }
  // The lowest surface above each footprint cell that is not the underside (the inner floor of a tube, the
  // top of a plate): the table can be seen there only if the part is not.
  for (size_t i = 0; i < model.footprint.on.size(); ++i) {
    if (!model.footprint.on[i]) continue;
    const Eigen::Vector2d xy = model.footprint.centre(static_cast<long>(i));
    const Vec3 top(xy.x(), xy.y(), model.height + 0.01);
    double lowest = 0.0;
    for (double t = 0.0;;) {
      const double hit = rays.hit(top, -Vec3::UnitZ(), t);
      if (!std::isfinite(hit)) break;
      const double z = top.z() - hit;
      if (z > 1e-4) lowest = z;
      t = hit + 1e-5;
    }
    model.footprint.value[i] = static_cast<float>(lowest);
  }

  // The lazy nearest-sample grid.
  model.cache_origin = model.lo - Vec3::Constant(model.cache_margin);
  const Vec3 ext = model.hi - model.lo + Vec3::Constant(2 * model.cache_margin);
  model.cx = static_cast<int>(ext.x() / model.cache_cell) + 1;
  model.cy = static_cast<int>(ext.y() / model.cache_cell) + 1;
  model.cz = static_cast<int>(ext.z() / model.cache_cell) + 1;
  model.cache.assign(
      static_cast<size_t>(model.cx) * static_cast<size_t>(model.cy) * static_cast<size_t>(model.cz), -2);
}

// Erodes a footprint by r cells (a cell stays on if every cell within r does).
Grid2 eroded(const Grid2& g, int r) {
  Grid2 out = g;
  for (int y = 0; y < g.ny; ++y)
    for (int x = 0; x < g.nx; ++x) {
      bool all = g.on[static_cast<size_t>(y * g.nx + x)] != 0;
      for (int dy = -r; dy <= r && all; ++dy)
        for (int dx = -r; dx <= r && all; ++dx) {
          const int xx = x + dx, yy = y + dy;
          all = xx >= 0 && yy >= 0 && xx < g.nx && yy < g.ny && g.on[static_cast<size_t>(yy * g.nx + xx)];
        }
      out.on[static_cast<size_t>(y * g.nx + x)] = all;
    }
  return out;
}

// --------------------------------------------------------------------------------------- search and refine

struct Context {
  Context(const LocalizeSetting& setting, Model& m) : s(setting), model(m) {}
  const LocalizeSetting& s;
  Model& model;
  double noise = 0.001;
  double trim = 0.0025, edge_margin = 0.002, height_cut = 0.005, inlier = 0.003;
  // Points near the table (table frame), averaged per 2 mm cell: where the outline of a part too low for
  // its walls to be told from the table is read from the change of height across it.
  Grid2 low;
  std::vector<float> low_sum;
  std::vector<uint16_t> low_count;
  double outline_max_top = 0.0;  // outline samples of parts at most this high are read this way
};

// For every low outline sample: walk across the outline (-8..+8 mm), classify the cells as raised (above half
// the part's height there) or table, and put the edge where the fewest cells disagree. Adds the residual of
// the edge found (along the outward normal) to the (yaw, x, y) normal equations.
int add_outline_terms(Context& c, const Iso3& P, Mat3& A, Vec3& b) {
  const Model& m = c.model;
  if (m.outline.empty() || c.low_sum.empty()) return 0;
  const Iso3 T = P.inverse();  // part -> table
  int used = 0;
  constexpr int kSteps = 17;
  for (const Model::OutlineSample& o : m.outline) {
    if (o.top > c.outline_max_top) continue;
    int cls[kSteps];  // 1 raised, 0 table, -1 no data
    int known = 0, raised = 0;
    for (int k = 0; k < kSteps; ++k) {
      const Eigen::Vector2d x = o.at + 0.001 * (k - kSteps / 2) * o.out;
      const Vec3 q = T * Vec3(x.x(), x.y(), 0.0);
      const long i = c.low.index(q.x(), q.y());
      cls[k] = -1;
      if (i < 0 || c.low_count[static_cast<size_t>(i)] == 0) continue;
      cls[k] = c.low_sum[static_cast<size_t>(i)] / c.low_count[static_cast<size_t>(i)] > 0.5 * o.top;
      ++known;
      raised += cls[k];
    }
    if (known < 10 || raised == 0 || raised == known) continue;
    // Edge between step e-1 and e: disagreements = raised cells outside + table cells inside. Where cells
    // without returns leave a tie, they are the shadow the raised part casts on the table behind its edge:
    // the edge is at the raised end of the gap, the innermost of the tied positions.
    int best = 1 << 30, best_e = 0;
    for (int e = 0; e <= kSteps; ++e) {
      int cost = 0;
      for (int k = 0; k < kSteps; ++k)
        if (cls[k] >= 0) cost += (k >= e) ? cls[k] == 1 : cls[k] == 0;
      if (cost < best) best = cost, best_e = e;
    }
    const double t = 0.001 * (best_e - 0.5 - kSteps / 2);  // edge offset along the outward normal
    if (std::abs(t) > 0.006 || best > known / 4) continue;
    const Eigen::Vector2d e2 = o.at + t * o.out;
    const Vec3 J(e2.x() * o.out.y() - e2.y() * o.out.x(), o.out.x(), o.out.y());
    A += J * J.transpose();
    b -= J * t;
    ++used;
  }
  return used;
}

struct Hypothesis {
  double x = 0, y = 0, yaw = 0;
  int votes = 0;
};

// (x, y, yaw) point-to-plane ICP of scan points (table frame) onto the model. P maps the table frame into the
// part frame. A correspondence counts only on a visible sample away from feature edges, with a residual
// within the cut-off, the trim and half the wall behind it — each limit symmetric about the surface, so
// noise does not push the answer one way. `fine`: no point-to-point steps first, thin walls handled, and
// where the rays are known, each is matched with the face it meets when cast against the model.
struct IcpResult {
  Iso3 P;
  int iterations = 0;
  bool converged = false;
};

// A scan point, and the centroid of its neighbourhood: which model face and sample a point is matched with
// is decided by the centroid, whose noise is a fraction of the point's own, so that the choice does not
// depend on where the point's noise threw it (near an edge, a ray's noise moves a point both off the face and
// along it; a choice by the point itself would keep one sign of the noise and drop the other). Where the ray
// is known, the ray itself decides, and no noise enters the choice at all.
struct ScanPoint {
  Vec3 raw, smooth;
  Vec3 ray = Vec3::Zero();     ///< unit direction from the sensor to the point (table frame), when known
  Vec3 origin = Vec3::Zero();  ///< the sensor's position (table frame), when the ray is known
  double range = 0.0;          ///< 0: the ray is not known
};

IcpResult icp(const std::vector<ScanPoint>& scan, Context& c, Iso3 P, int iterations, bool fine) {
  IcpResult out;
  Model& m = c.model;
  // Far from the answer, a few closed-form point-to-point steps (each scan point moved onto its nearest
  // visible model sample) pull in faster and more steadily than linearized point-to-plane steps.
  for (int it = 0; !fine && it < c.s.point_to_point_iterations; ++it) {
    std::vector<Vec3> from, to;
    for (const ScanPoint& sp : scan) {
      const Vec3 p = P * sp.raw;
      const int k = m.nearest(p);
      if (k < 0 || !m.visible[static_cast<size_t>(k)] ||
          (p - m.pts[static_cast<size_t>(k)]).norm() > c.s.icp_start_distance_m)
        continue;
      from.push_back(p);
      to.push_back(m.pts[static_cast<size_t>(k)]);
    }
    if (from.size() < 20) break;
    P = planar_rigid_fit(from, to) * P;
  }
  const bool cast = fine && !scan.empty() && scan.front().range > 0;
  std::vector<int> face(cast ? scan.size() : 0, -1);
  for (int it = 0; it < iterations; ++it) {
    const double f = iterations > 1 ? static_cast<double>(it) / (iterations - 1) : 1.0;
    const double max_d = std::max(c.trim, c.s.icp_start_distance_m + f * (c.trim - c.s.icp_start_distance_m));
    Mat3 A = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    int used = 0;
    if (cast) {
      // Each ray is matched with the face it would meet were the pose right: the choice depends on where the
      // sensor looked, never on where the range noise threw the point, so no sign of the noise is dropped.
      for (size_t i = 0; i < scan.size(); ++i) {
        const ScanPoint& sp = scan[i];
        const Vec3 o = P * sp.origin, d = P.linear() * sp.ray;
        const double t = m.rays->hit(o, d, 0.0, sp.range + kRayWindow);
        face[i] = -1;
        if (!std::isfinite(t) || t < sp.range - kRayWindow) continue;  // the ray meets something else
        const Vec3 at = o + t * d;
        const int k = m.nearest(at);
        if (k < 0) continue;
        const size_t kk = static_cast<size_t>(k);
        // Level faces say nothing of (x, y, yaw); near a feature edge or the table, which face a ray meets
        // changes with the pose itself.
        if (std::abs(m.nrm[kk].z()) > 0.95 || m.nrm[kk].dot(d) >= 0.0 || !m.visible[kk] ||
            m.edge_distance[kk] < c.edge_margin || at.z() < c.edge_margin)
          continue;
        face[i] = k;
      }
      for (size_t i = 0; i < scan.size(); ++i) {
        if (face[i] < 0) continue;
        const size_t kk = static_cast<size_t>(face[i]);
        const Vec3& n = m.nrm[kk];
        const Vec3 p = P * scan[i].raw;
        const double r = (p - m.pts[kk]).dot(n);
        if (std::abs(r) > max_d) continue;
        const Vec3 J(p.x() * n.y() - p.y() * n.x(), n.x(), n.y());
        A += J * J.transpose();
        b -= J * r;
        ++used;
      }
    }
    for (const ScanPoint& sp : scan) {
      if (cast) break;  // the rays have been matched above
      const Vec3 p = P * sp.raw;
      const int k = m.nearest(P * sp.smooth);
      if (k < 0) continue;
      const size_t kk = static_cast<size_t>(k);
      if (m.edge_distance[kk] < c.edge_margin) continue;
      const Vec3& n = m.nrm[kk];
      const Vec3 d = p - m.pts[kk];
      const double r = d.dot(n);
      if ((d - r * n).squaredNorm() > 9 * c.s.model_spacing_m * c.s.model_spacing_m) continue;
      const Vec3 J(p.x() * n.y() - p.y() * n.x(), n.x(), n.y());
      const double h = m.half_thickness[kk];
      double limit = max_d;
      if (fine && h < c.trim) {
        // A thin wall, seen on both sides: noise this wide carries points across its middle, so a point
        // taken for the side seen less (an inner wall seen only steeply) may well belong to the other side.
        // Only the better-seen side is used, trimmed at the middle so its own noise stays symmetric.
        const int kb = m.nearest(m.pts[kk] - 2 * h * n);
        if (kb >= 0 && m.nrm[static_cast<size_t>(kb)].dot(n) < -0.5 &&
            m.view_score[static_cast<size_t>(kb)] > m.view_score[kk])
          continue;
        limit = std::min(max_d, h);
      }
      if (!m.visible[kk] || std::abs(r) > limit) continue;
      A += J * J.transpose();
      b -= J * r;
      ++used;
    }
    // Without rays, the outline of a part too low to be told from the table is read from the height step;
    // with them, the plate's own walls take part (the rays tell them from the table).
    if (!cast) used += add_outline_terms(c, P, A, b);
    out.iterations = it + 1;
    if (used < 20) break;
    A += 1e-9 * Mat3::Identity();
    const Vec3 xi = A.ldlt().solve(b);
    P = planar_pose(xi.y(), xi.z(), 0.0, xi.x()) * P;
    if (f >= 1.0) out.converged = std::abs(xi.x()) * 0.1 + xi.tail<2>().norm() < 1e-6;
  }
  out.P = orthonormalized(P);
  return out;
}

struct Score {
  int inliers = 0, region = 0;
  double wall_residual = 0.0;  ///< median |residual| of the points near walls, in noise sigmas
  double rmse = 0.0, coverage = 0.0, free_space = 0.0;
  double max_free = 0.02;
  /// Evidence for the pose: scan points it explains times the share of its visible surface the scan
  /// confirms, discounted by the table seen where it would stand.
  double support() const { return inliers * coverage * std::max(0.0, 1.0 - free_space / max_free); }
};

Score score(const std::vector<Vec3>& scan, const PointTree& scan_tree, const Grid2& footprint, Context& c,
            const Iso3& P) {
  Score out;
  Model& m = c.model;
  double sum2 = 0.0;
  std::vector<double> wall;
  for (const Vec3& q : scan) {
    if (q.z() < c.height_cut) continue;
    const Vec3 p = P * q;
    if (p.x() < m.lo.x() - 0.005 || p.y() < m.lo.y() - 0.005 || p.x() > m.hi.x() + 0.005 ||
        p.y() > m.hi.y() + 0.005 || p.z() > m.hi.z() + 0.005)
      continue;
    ++out.region;
    const int k = m.nearest(p);
    if (k < 0) continue;
    const Vec3 d = p - m.pts[static_cast<size_t>(k)];
    const double r = d.dot(m.nrm[static_cast<size_t>(k)]);
    if (std::abs(m.nrm[static_cast<size_t>(k)].z()) < 0.5 && m.visible[static_cast<size_t>(k)] &&
        d.squaredNorm() < 0.01 * 0.01)
      wall.push_back(std::abs(r) / c.noise);
    if (std::abs(r) < c.inlier && d.squaredNorm() < 4 * c.inlier * c.inlier) {
      ++out.inliers;
      sum2 += r * r;
    }
  }
  out.rmse = out.inliers ? std::sqrt(sum2 / out.inliers) : 1.0;
  out.wall_residual = median(wall);
  // Coverage: visible samples facing up or sideways, high enough to be told from the table, with a scan
  // point near.
  const Iso3 T = P.inverse();
  const double reach = std::max(0.004, 2 * c.noise);
  int seen = 0, total = 0;
  double d2 = 0.0;
  for (size_t k = 0; k < m.pts.size(); k += 3) {
    if (!m.visible[k] || m.nrm[k].z() < -0.2 || m.pts[k].z() < c.height_cut) continue;
    ++total;
    if (scan_tree.nearest(T * m.pts[k], d2) >= 0 && d2 < reach * reach) ++seen;
  }
  out.coverage = total ? static_cast<double>(seen) / total : 0.0;
  // Free space: the table seen where the part would rest on it, clearly below the part's lowest surface
  // there (cells averaged, so that single noisy points do not count).
  int cells = 0, through = 0;
  for (size_t i = 0; i < footprint.on.size(); ++i) {
    if (!footprint.on[i]) continue;
    ++cells;
    const Eigen::Vector2d xy = footprint.centre(static_cast<long>(i));
    const Vec3 q = T * Vec3(xy.x(), xy.y(), 0.0);
    const long j = c.low.index(q.x(), q.y());
    if (j < 0 || c.low_count[static_cast<size_t>(j)] == 0) continue;
    const double mean = c.low_sum[static_cast<size_t>(j)] / c.low_count[static_cast<size_t>(j)];
    through += mean < footprint.value[i] - 3 * c.noise;
  }
  out.free_space = cells ? static_cast<double>(through) / cells : 0.0;
  out.max_free = c.s.max_free_space;
  return out;
}

// Whether the model maps onto itself under D (part frame): a symmetry, so poses D apart are the same weld.
bool self_similar(Model& model, const Iso3& D) {
  double sum = 0.0;
  int n = 0;
  double d2 = 0.0;
  for (size_t k = 0; k < model.pts.size(); k += 7) {
    if (!model.visible[k]) continue;
    if (model.tree.nearest(D * model.pts[k], d2) < 0) continue;
    sum += std::sqrt(d2);
    ++n;
  }
  return n > 0 && sum / n < 0.0015;
}

// Whether D (part frame to part frame) maps every seam point within 1.5 mm of some seam point (they are about
// 1 mm apart).
bool same_seams(const std::vector<Vec3>& seam, const Iso3& D) {
  if (seam.empty()) return false;
  for (const Vec3& p : seam) {
    const Vec3 q = D * p;
    double best = 1e9;
    for (const Vec3& r : seam) best = std::min(best, (q - r).squaredNorm());
    if (best > 1.5e-3 * 1.5e-3) return false;
  }
  return true;
}

template <typename T>
std::vector<T> thinned(const std::vector<T>& v, size_t max) {
  if (v.size() <= max) return v;
  std::vector<T> out;
  out.reserve(max);
  const double step = static_cast<double>(v.size()) / static_cast<double>(max);
  for (size_t i = 0; i < max; ++i) out.push_back(v[static_cast<size_t>(static_cast<double>(i) * step)]);
  return out;
}

}  // namespace

struct PreparedPart::Impl {
  Model model;
  double min_z = 0.0;  ///< the mesh's lowest vertex: the resting frame is the mesh frame lifted by it
  double model_spacing_m = 0.0;  ///< the setting it was prepared with
};

PreparedPart::PreparedPart(const Mesh& mesh, const LocalizeSetting& setting)
    : impl_(std::make_shared<Impl>()) {
  impl_->min_z = 1e9;
  for (const Vec3& v : mesh.vertices) impl_->min_z = std::min(impl_->min_z, v.z());
  impl_->model_spacing_m = setting.model_spacing_m;
  build_model(mesh, impl_->min_z, setting, impl_->model);
}

PoseEstimate localize(const std::vector<Vec3>& scan_base, const Mesh& mesh, const LocalizeSetting& s,
                      const std::vector<Vec3>& seam_points, const std::vector<Vec3>& viewpoints_base) {
  const auto t0 = Clock::now();
  const PreparedPart part(mesh, s);
  const double model_s = std::chrono::duration<double>(Clock::now() - t0).count();
  PoseEstimate out = localize(scan_base, part, s, seam_points, viewpoints_base);
  out.seconds += model_s;
  if (!out.stage_seconds.empty()) out.stage_seconds.front().second += model_s;
  return out;
}

PoseEstimate localize(const std::vector<Vec3>& scan_base, const PreparedPart& part, const LocalizeSetting& s,
                      const std::vector<Vec3>& seam_points, const std::vector<Vec3>& viewpoints_base) {
  if (s.model_spacing_m != part.impl_->model_spacing_m)
    throw std::invalid_argument("localize: the part was prepared with another model spacing");
  const auto t0 = Clock::now();
  auto lap = t0;
  PoseEstimate out;
  auto stage = [&](const char* name) {
    const auto now = Clock::now();
    out.stage_seconds.emplace_back(name, std::chrono::duration<double>(now - lap).count());
    lap = now;
  };
  auto finish = [&](const std::string& reason) {
    out.reason = reason;
    out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return out;
  };

  const double min_z = part.impl_->min_z;
  Model& model = part.impl_->model;  // its nearest-sample grid fills as it is asked (the same answers)
  stage("model");
  if (model.pts.size() < 50) return finish("the model mesh is too small to sample");

  // Table plane, range noise, and the limits that follow from the noise.
  double noise = s.min_noise_m;
  if (!find_table_plane(scan_base, s, out.table_plane, noise)) return finish("no table plane in the scan");
  out.noise_m = noise;
  Context c(s, model);
  c.noise = noise;
  c.trim = s.noise_trim * noise;
  c.inlier = std::max(0.0015, 2.5 * noise);
  c.edge_margin = s.edge_margin_sigmas * noise;
  c.height_cut = std::max(s.min_height_m, s.height_cut_sigmas * noise);
  const Iso3 T_base_table = table_frame(out.table_plane), T_table_base = T_base_table.inverse();
  stage("table");

  // Object points above the table (table frame), and the points near the table by cell.
  std::vector<Vec3> above;
  c.outline_max_top = 3 * c.height_cut;
  c.low.reset(Eigen::Vector2d::Constant(-s.reach_radius_m), Eigen::Vector2d::Constant(s.reach_radius_m),
              0.002);
  c.low_sum.assign(c.low.on.size(), 0.0f);
  c.low_count.assign(c.low.on.size(), 0);
  const double low_top = c.outline_max_top + 3 * noise;
  // With the sensor's position for every point, the fine refinement casts the rays themselves against the
  // model (a voxel's centroid would mix the two sides of a thin wall, and a point's own position, thrown by
  // the noise, cannot say which side it is on).
  // Viewpoints that cannot be a LiDAR looking down at the table (all zero, as some tools fill PCL's
  // PointWithViewpoint) are not used: a ray cast from the wrong place would match points with wrong faces.
  bool rays = viewpoints_base.size() == scan_base.size() && !scan_base.empty();
  if (rays) {
    size_t above_table = 0, looked = 0;
    for (size_t i = 0; i < viewpoints_base.size(); i += 97, ++looked)
      above_table += (T_table_base * viewpoints_base[i]).z() > kMinViewpointHeight;
    rays = above_table >= 0.9 * static_cast<double>(looked);
  }
  std::vector<uint32_t> ray_points;  // every point near or above the table, when the rays are known
  for (size_t i = 0; i < scan_base.size(); ++i) {
    const Vec3& p = scan_base[i];
    const double rxy = p.head<2>().norm();
    if (rxy < s.base_keepout_m || rxy > s.reach_radius_m) continue;
    const Vec3 q = T_table_base * p;
    if (rays && q.z() > -3 * noise && q.z() < model.height + 0.05)
      ray_points.push_back(static_cast<uint32_t>(i));
    if (q.z() > -3 * noise && q.z() < low_top) {
      const long cell = c.low.index(q.x(), q.y());
      if (cell >= 0 && c.low_count[static_cast<size_t>(cell)] < 60000) {
        c.low_sum[static_cast<size_t>(cell)] += static_cast<float>(q.z());
        ++c.low_count[static_cast<size_t>(cell)];
      }
    }
    if (q.z() < s.min_height_m || q.z() > model.height + 0.05) continue;
    above.push_back(q);
  }
  if (above.size() < 50) return finish("nothing stands on the table");
  Cloud::Ptr objects(new Cloud);
  {
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setInputCloud(to_cloud(above));
    const float leaf = static_cast<float>(s.voxel_m);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.filter(*objects);
  }
  out.object_points = static_cast<int>(objects->size());
  if (objects->size() < 50) return finish("nothing stands on the table");
  std::vector<Vec3> scan;
  scan.reserve(objects->size());
  for (const auto& p : *objects) scan.emplace_back(p.x, p.y, p.z);
  const PointTree scan_tree(scan);
  const Grid2 footprint =
      eroded(model.footprint, static_cast<int>(std::ceil(std::max(0.003, 2 * noise) / 0.002)));
  stage("objects");

  // Hough voting over (x, y, yaw): a scan wall point at height z with horizontal normal direction a, matched
  // with a model wall point at the same height with normal direction b, votes for yaw = a - b (and a - b +
  // pi, for PCA normals have no sign) and the translation that puts the model point on the scan point.
  std::vector<size_t> voters;
  for (size_t i = 0; i < scan.size(); ++i)
    if (scan[i].z() >= c.height_cut) voters.push_back(i);
  if (voters.size() < 20) return finish("nothing part-like stands on the table");
  std::unordered_map<long long, int> votes;
  const int yaw_bins = static_cast<int>(std::round(360.0 / s.vote_yaw_deg));
  auto key = [&](int ix, int iy, int iw) {
    return (static_cast<long long>(ix + 100000) * 200003LL + (iy + 100000)) * 1024LL + iw;
  };
  const size_t stride = std::max<size_t>(1, voters.size() / static_cast<size_t>(s.vote_points));
  std::vector<uint32_t> nidx;
  std::vector<double> nd2;
  for (size_t v = 0; v < voters.size(); v += stride) {
    const Vec3& q = scan[voters[v]];
    if (scan_tree.knn(q, static_cast<size_t>(s.normal_neighbours), nidx, nd2) < 6) continue;
    Vec3 mean = Vec3::Zero();
    for (uint32_t j : nidx) mean += scan[j];
    mean /= static_cast<double>(nidx.size());
    Mat3 C = Mat3::Zero();
    for (uint32_t j : nidx) C += (scan[j] - mean) * (scan[j] - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    const Vec3 nn = eig.eigenvectors().col(0);
    if (std::abs(nn.z()) > 0.5) continue;
    const double a = std::atan2(nn.y(), nn.x());
    const long bin = static_cast<long>(q.z() / kHeightBin);
    for (long hb = bin - 1; hb <= bin + 1; ++hb) {
      if (hb < 0 || hb >= static_cast<long>(model.walls_by_height.size())) continue;
      for (int k : model.walls_by_height[static_cast<size_t>(hb)]) {
        const Vec3& mp = model.pts[static_cast<size_t>(k)];
        const Vec3& mn = model.nrm[static_cast<size_t>(k)];
        const double b = std::atan2(mn.y(), mn.x());
        for (double flip : {0.0, kPi}) {
          double yaw = std::remainder(a - b + flip, 2 * kPi);
          if (yaw < 0) yaw += 2 * kPi;
          const double cy = std::cos(yaw), sy = std::sin(yaw);
          const double tx = q.x() - (cy * mp.x() - sy * mp.y()), ty = q.y() - (sy * mp.x() + cy * mp.y());
          const int iw = static_cast<int>(yaw / deg2rad(s.vote_yaw_deg)) % yaw_bins;
          ++votes[key(static_cast<int>(std::floor(tx / s.vote_xy_m)),
                      static_cast<int>(std::floor(ty / s.vote_xy_m)), iw)];
        }
      }
    }
  }
  if (votes.empty()) return finish("no part-like walls on the table");
  // Peaks: the best raw bins, ranked by the votes of their 3x3x3 neighbourhood, at least a bin apart.
  std::vector<std::pair<int, long long>> ranked;
  ranked.reserve(votes.size());
  for (const auto& [k, v] : votes) ranked.emplace_back(v, k);
  const size_t top = std::min<size_t>(ranked.size(), 400);
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<long>(top), ranked.end(),
                    [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<Hypothesis> peaks;
  for (size_t r = 0; r < top; ++r) {
    const long long k = ranked[r].second;
    const int iw = static_cast<int>(k % 1024);
    const long long rk = k / 1024;
    const int iy = static_cast<int>(rk % 200003LL) - 100000, ix = static_cast<int>(rk / 200003LL) - 100000;
    int sum = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dw = -1; dw <= 1; ++dw) {
          const auto it = votes.find(key(ix + dx, iy + dy, (iw + dw + yaw_bins) % yaw_bins));
          if (it != votes.end()) sum += it->second;
        }
    peaks.push_back(
        {(ix + 0.5) * s.vote_xy_m, (iy + 0.5) * s.vote_xy_m, (iw + 0.5) * deg2rad(s.vote_yaw_deg), sum});
  }
  std::stable_sort(peaks.begin(), peaks.end(),
                   [](const auto& a, const auto& b) { return a.votes > b.votes; });
  std::vector<Hypothesis> hyps;
  if (s.use_initial_guess) {
    const Iso3 T = T_table_base * s.initial_guess * make_transform(Vec3(0, 0, min_z), Mat3::Identity());
    peaks.insert(peaks.begin(), {T.translation().x(), T.translation().y(),
                                 std::atan2(T.linear()(1, 0), T.linear()(0, 0)), 1 << 30});
  }
  for (const Hypothesis& h : peaks) {
    if (static_cast<int>(hyps.size()) >= s.hypotheses) break;
    bool close = false;
    for (const Hypothesis& o : hyps)
      close = close || (std::hypot(o.x - h.x, o.y - h.y) < 0.01 &&
                        std::abs(std::remainder(o.yaw - h.yaw, 2 * kPi)) < deg2rad(6));
    if (!close) hyps.push_back(h);
  }
  stage("search");

  // Refinement: every peak coarsely, the best few fully. Only points high enough to be told from the table
  // take part.
  std::vector<ScanPoint> icp_points;
  {
    std::vector<uint32_t> idx;
    std::vector<double> d2;
    const double r2 = std::pow(std::max(0.004, 2 * noise), 2);
    for (const Vec3& q : scan) {
      if (q.z() < c.height_cut) continue;
      Vec3 mean = Vec3::Zero();
      int n = 0;
      if (scan_tree.knn(q, static_cast<size_t>(s.smoothing_neighbours), idx, d2) > 0)
        for (size_t j = 0; j < idx.size(); ++j)
          if (d2[j] <= r2) mean += scan[idx[j]], ++n;
      icp_points.push_back({q, n ? Vec3(mean / n) : q});
    }
  }
  struct Refined {
    Iso3 P;
    IcpResult icp;
    Score score;
  };
  // The points around a pose that can move (x, y, yaw): those nearest a face that is not level (a level
  // face's residual does not change with them).
  auto near_pose = [&](const Iso3& P, const std::vector<ScanPoint>& from) {
    std::vector<ScanPoint> near;
    for (const ScanPoint& sp : from) {
      const Vec3& q = sp.raw;
      const Vec3 p = P * q;
      if (p.x() < model.lo.x() - 0.02 || p.y() < model.lo.y() - 0.02 || p.x() > model.hi.x() + 0.02 ||
          p.y() > model.hi.y() + 0.02)
        continue;
      const int k = model.nearest(p);
      if (k >= 0 && std::abs(model.nrm[static_cast<size_t>(k)].z()) > 0.95 &&
          (p - model.pts[static_cast<size_t>(k)]).norm() < 0.004)
        continue;
      near.push_back(sp);
    }
    return near;
  };
  // With rays: every ray that may meet a face that can move (x, y, yaw) at pose P: table-level points near
  // the footprint's outline (the plate's walls), and the rest unless deep inside a level face (where no noise
  // can carry a point off it).
  auto near_rays = [&](const Iso3& P) {
    std::vector<ScanPoint> near;
    const double band = 0.008, deep = 3 * noise + 0.002;
    auto on = [&](const Vec3& x) {
      const long i = model.footprint.index(x.x(), x.y());
      return i >= 0 && model.footprint.on[static_cast<size_t>(i)];
    };
    for (uint32_t i : ray_points) {
      const Vec3 q = T_table_base * scan_base[i];
      const Vec3 p = P * q;
      if (p.x() < model.lo.x() - 0.015 || p.y() < model.lo.y() - 0.015 || p.x() > model.hi.x() + 0.015 ||
          p.y() > model.hi.y() + 0.015)
        continue;
      if (q.z() < c.height_cut) {
        const bool here = on(p);
        if (here == on(p + Vec3(band, 0, 0)) && here == on(p - Vec3(band, 0, 0)) &&
            here == on(p + Vec3(0, band, 0)) && here == on(p - Vec3(0, band, 0)))
          continue;
      } else {
        const int k = model.nearest(p);
        if (k >= 0 && std::abs(model.nrm[static_cast<size_t>(k)].z()) > 0.95 &&
            (p - model.pts[static_cast<size_t>(k)]).norm() < 0.004 &&
            model.edge_distance[static_cast<size_t>(k)] > deep)
          continue;
      }
      const Vec3 o = T_table_base * viewpoints_base[i];
      const double range = (q - o).norm();
      if (range < 1e-6) continue;
      near.push_back({q, q, (q - o) / range, o, range});
    }
    return near;
  };
  std::vector<Refined> coarse;
  // A quick look at every peak (how many of a thin sample of points lie near the model there) decides
  // which are worth refining.
  {
    const std::vector<ScanPoint> probe = thinned(icp_points, 800);
    std::vector<std::pair<int, size_t>> quick;
    for (size_t i = 0; i < hyps.size(); ++i) {
      const Iso3 P0 = planar_pose(hyps[i].x, hyps[i].y, 0.0, hyps[i].yaw).inverse();
      int near = 0;
      for (const ScanPoint& sp : probe) {
        const Vec3 p = P0 * sp.raw;
        const int k = model.nearest(p);
        near += k >= 0 && (p - model.pts[static_cast<size_t>(k)]).squaredNorm() < 36e-6;
      }
      quick.emplace_back(near, i);
    }
    std::stable_sort(quick.begin(), quick.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<Hypothesis> kept;
    for (size_t i = 0; i < quick.size() && static_cast<int>(kept.size()) < s.refined_hypotheses; ++i)
      kept.push_back(hyps[quick[i].second]);
    hyps.swap(kept);
  }
  coarse.resize(hyps.size());
  parallel_for(hyps.size(), s.threads, [&](size_t i) {
    const Iso3 P0 = planar_pose(hyps[i].x, hyps[i].y, 0.0, hyps[i].yaw).inverse();
    const IcpResult r = icp(thinned(near_pose(P0, icp_points), static_cast<size_t>(s.coarse_points)), c, P0,
                            s.coarse_iterations, false);
    coarse[i] = {r.P, r, score(scan, scan_tree, footprint, c, r.P)};
  });
  // A pose that puts the part where the table is seen is no candidate; of the rest, the best few distinct.
  auto better = [&](const Refined& a, const Refined& b) {
    const bool fa = a.score.free_space <= s.max_free_space, fb = b.score.free_space <= s.max_free_space;
    if (fa != fb) return fa;
    return a.score.support() > b.score.support();
  };
  std::sort(coarse.begin(), coarse.end(), better);
  std::vector<const Refined*> chosen;  // the best few distinct coarse poses
  for (const Refined& r : coarse) {
    if (static_cast<int>(chosen.size()) >= s.finalists) break;
    bool dup = false;
    for (const Refined* o : chosen) {
      const Iso3 D = o->P * r.P.inverse();
      dup = dup || (D.translation().norm() < 0.004 && Eigen::AngleAxisd(D.linear()).angle() < deg2rad(2));
    }
    if (!dup) chosen.push_back(&r);
  }
  std::vector<Refined> refined(chosen.size());
  parallel_for(chosen.size(), s.threads, [&](size_t i) {
    const Iso3& P = chosen[i]->P;
    const std::vector<ScanPoint> near = thinned(ray_points.empty() ? near_pose(P, icp_points) : near_rays(P),
                                                static_cast<size_t>(s.icp_max_points));
    const IcpResult f = icp(near, c, P, s.fine_iterations, true);
    refined[i] = {f.P, f, score(scan, scan_tree, footprint, c, f.P)};
  });
  std::sort(refined.begin(), refined.end(), better);
  stage("refine");
  if (refined.empty()) return finish("no pose survived the refinement");
  const Refined& best = refined.front();

  // Ambiguity: the best distinct pose that is not the same weld by the part's symmetry, among the coarse and
  // the refined poses that the free space allows.
  const Iso3 lift = make_transform(Vec3(0, 0, -min_z), Mat3::Identity());  // mesh frame -> resting frame
  std::vector<const Refined*> rivals;
  for (const Refined& r : refined) rivals.push_back(&r);
  for (const Refined& r : coarse) rivals.push_back(&r);
  for (const Refined* r : rivals) {
    if (r == &best || r->score.free_space > s.max_free_space) continue;
    const Iso3 D = best.P * r->P.inverse();  // part frame to part frame
    // The same pose found twice, or a shallower minimum next to it: not a rival.
    if (D.translation().norm() < 0.008 && Eigen::AngleAxisd(D.linear()).angle() < deg2rad(5)) continue;
    if (self_similar(model, D)) continue;
    if (same_seams(seam_points, lift.inverse() * D * lift)) continue;
    out.ambiguity = std::max(out.ambiguity, r->score.support() / std::max(1e-9, best.score.support()));
  }

  out.T_base_part = orthonormalized(T_base_table * best.P.inverse() * lift);
  out.fitness = best.score.region ? static_cast<double>(best.score.inliers) / best.score.region : 0.0;
  out.rmse_m = best.score.rmse;
  out.coverage = best.score.coverage;
  out.free_space = best.score.free_space;
  out.wall_residual = best.score.wall_residual;
  out.converged = best.icp.converged;
  out.iterations = best.icp.iterations;
  out.inliers = best.score.inliers;
  out.rays_cast = !ray_points.empty();
  stage("verdict");
  if (out.free_space > s.max_free_space) return finish("the table is seen where the best match would stand");
  if (out.coverage < s.min_coverage) return finish("the best match covers too little of the model");
  if (out.fitness < s.min_fitness) return finish("the part fits the scan poorly");
  if (out.wall_residual > s.max_wall_residual)
    return finish("the part's walls fit the scan worse than the noise explains: a different part?");
  if (out.ambiguity >= s.ambiguity_ratio) return finish("ambiguous: a different pose fits almost as well");
  out.found = true;
  return finish("");
}

}  // namespace weldtwin
