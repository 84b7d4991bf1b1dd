#include "perception/localizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/features/normal_3d.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

namespace weldtwin {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

Cloud::Ptr to_cloud(const std::vector<Vec3>& points) {
  Cloud::Ptr c(new Cloud);
  c->reserve(points.size());
  for (const Vec3& p : points)
    c->push_back(
        pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  return c;
}

Cloud::Ptr voxelized(const Cloud::Ptr& in, double leaf) {
  Cloud::Ptr out(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(in);
  grid.setLeafSize(static_cast<float>(leaf), static_cast<float>(leaf), static_cast<float>(leaf));
  grid.filter(*out);
  return out;
}

// The table: cascaded RANSAC for near-horizontal planes; of the big ones, the highest (the floor is bigger
// but lower). Refined by least squares on its inliers. Returns false if there is none.
bool find_table(const std::vector<Vec3>& scan, const LocalizeSetting& s, Eigen::Vector4d& plane) {
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // failures are reported as values, not on stderr
  std::vector<Vec3> near;
  for (const Vec3& p : scan)
    if (p.head<2>().norm() <= s.reach_radius_m) near.push_back(p);
  if (near.size() < 100) return false;
  Cloud::Ptr rest = voxelized(to_cloud(near), 0.01);
  struct Found {
    Eigen::Vector4d plane;
    size_t inliers;
  };
  std::vector<Found> planes;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setAxis(Eigen::Vector3f::UnitZ());
  seg.setEpsAngle(static_cast<float>(deg2rad(s.table_max_tilt_deg)));
  seg.setDistanceThreshold(std::max(s.table_threshold_m, 0.006));
  seg.setMaxIterations(400);
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
    planes.push_back({p, inliers.indices.size()});
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
    if (f.inliers * 5 >= biggest && (!table || -f.plane[3] > -table->plane[3])) table = &f;
  // Least-squares refinement on the full-resolution points close to it.
  Eigen::Vector4d p = table->plane;
  for (int it = 0; it < 3; ++it) {
    Vec3 c = Vec3::Zero();
    std::vector<Vec3> in;
    for (const Vec3& q : near)
      if (std::abs(p.head<3>().dot(q) + p[3]) < s.table_threshold_m) in.push_back(q);
    if (in.size() < 50) break;
    for (const Vec3& q : in) c += q;
    c /= static_cast<double>(in.size());
    Mat3 C = Mat3::Zero();
    for (const Vec3& q : in) C += (q - c) * (q - c).transpose();
    Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    Vec3 n = eig.eigenvectors().col(0);
    if (n.z() < 0) n = -n;
    p << n, -n.dot(c);
  }
  plane = p;
  return true;
}

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

struct Model {
  SurfaceSamples samples;  // part frame, shifted to rest on z = 0
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  double radius = 0.0, height = 0.0;
  std::vector<std::vector<int>> walls_by_height;  // indices of wall samples per 2 mm height bin
};

constexpr double kHeightBin = 0.002;

struct Hypothesis {
  double x = 0, y = 0, yaw = 0;
  int votes = 0;
};

// Robust point-to-plane ICP of the scan onto the model. P maps table-frame points into the part frame.
struct IcpResult {
  Iso3 P;
  int iterations = 0;
  bool converged = false;
};

IcpResult icp(const std::vector<Vec3>& all, const Model& model, Iso3 P, const LocalizeSetting& s) {
  IcpResult out;
  // The points that can take part: around the hypothesis, with room for its error.
  std::vector<Vec3> near;
  for (const Vec3& q : all) {
    const Vec3 p = P * q;
    if (p.head<2>().norm() <= model.radius + 0.04 && p.z() <= model.height + 0.03) near.push_back(q);
  }
  // A few thousand points pin six degrees of freedom down well; more only cost time.
  std::vector<Vec3> scan;
  const size_t stride = std::max<size_t>(1, near.size() / static_cast<size_t>(s.icp_max_points));
  for (size_t i = 0; i < near.size(); i += stride) scan.push_back(near[i]);
  std::vector<int> idx(1);
  std::vector<float> d2(1);
  for (int it = 0; it < s.icp_iterations; ++it) {
    const double f = s.icp_iterations > 1 ? static_cast<double>(it) / (s.icp_iterations - 1) : 1.0;
    const double max_d = s.icp_start_distance_m + f * (s.icp_end_distance_m - s.icp_start_distance_m);
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    int used = 0;
    for (const Vec3& q : scan) {
      const Vec3 p = P * q;
      if (p.head<2>().norm() > model.radius + 0.02 || p.z() > model.height + 0.02) continue;
      const pcl::PointXYZ pp(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
      if (model.tree.radiusSearch(pp, max_d, idx, d2, 1) < 1) continue;
      const Vec3& m = model.samples.points[static_cast<size_t>(idx[0])];
      const Vec3& n = model.samples.normals[static_cast<size_t>(idx[0])];
      const double r = (p - m).dot(n);
      const double w = std::abs(r) <= s.huber_m ? 1.0 : s.huber_m / std::abs(r);  // Huber
      Eigen::Matrix<double, 6, 1> J;
      J << p.cross(n), n;  // d r / d (omega, v) for p' = p + omega x p + v
      A += w * J * J.transpose();
      b -= w * J * r;
      ++used;
    }
    out.iterations = it + 1;
    if (used < 20) break;
    const Eigen::Matrix<double, 6, 1> xi = A.ldlt().solve(b);
    Iso3 step = Iso3::Identity();
    step.linear() = Eigen::AngleAxisd(xi.head<3>().norm(),
                                      xi.head<3>().norm() > 0 ? xi.head<3>().normalized() : Vec3::UnitZ())
                        .toRotationMatrix();
    step.translation() = xi.tail<3>();
    P = step * P;
    if (xi.norm() < 1e-8 && f > 0.99) {
      out.converged = true;
      break;
    }
    if (it == s.icp_iterations - 1) out.converged = xi.norm() < 1e-6;
  }
  out.P = orthonormalized(P);
  return out;
}

struct Score {
  int inliers = 0, region = 0;
  double rmse = 0.0, coverage = 0.0;
};

Score score(const std::vector<Vec3>& scan, pcl::KdTreeFLANN<pcl::PointXYZ>& scan_tree, const Model& model,
            const Iso3& P, const LocalizeSetting& s) {
  Score out;
  std::vector<int> idx(1);
  std::vector<float> d2(1);
  double sum2 = 0.0;
  for (const Vec3& q : scan) {
    const Vec3 p = P * q;
    if (p.head<2>().norm() > model.radius + 0.005 || p.z() > model.height + 0.005) continue;
    const pcl::PointXYZ pp(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    ++out.region;
    if (model.tree.radiusSearch(pp, 2 * s.inlier_m, idx, d2, 1) < 1) continue;
    const size_t k = static_cast<size_t>(idx[0]);
    const double r = (p - model.samples.points[k]).dot(model.samples.normals[k]);
    if (std::abs(r) < s.inlier_m && d2[0] < 4 * s.inlier_m * s.inlier_m) {
      ++out.inliers;
      sum2 += r * r;
    }
  }
  out.rmse = out.inliers ? std::sqrt(sum2 / out.inliers) : 1.0;
  // Coverage: model samples facing up or sideways with a scan point within 4 mm.
  const Iso3 T = P.inverse();
  int seen = 0, total = 0;
  for (size_t k = 0; k < model.samples.points.size(); k += 3) {
    if (model.samples.normals[k].z() < -0.2) continue;
    ++total;
    const Vec3 q = T * model.samples.points[k];
    const pcl::PointXYZ pp(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
    if (scan_tree.radiusSearch(pp, 0.004, idx, d2, 1) > 0) ++seen;
  }
  out.coverage = total ? static_cast<double>(seen) / total : 0.0;
  return out;
}

// Whether the model maps onto itself under D (part frame): a symmetry, so poses D apart are the same weld.
bool self_similar(const Model& model, const Iso3& D) {
  std::vector<int> idx(1);
  std::vector<float> d2(1);
  double sum = 0.0;
  int n = 0;
  for (size_t k = 0; k < model.samples.points.size(); k += 7) {
    const Vec3 q = D * model.samples.points[k];
    const pcl::PointXYZ pp(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
    if (model.tree.nearestKSearch(pp, 1, idx, d2) < 1) continue;
    sum += std::sqrt(d2[0]);
    ++n;
  }
  return n > 0 && sum / n < 0.0015;
}

// Whether D (part frame to part frame) maps every seam point within 1 mm of some seam point.
bool same_seams(const std::vector<Vec3>& seam, const Iso3& D) {
  if (seam.empty()) return false;
  for (const Vec3& p : seam) {
    const Vec3 q = D * p;
    double best = 1e9;
    for (const Vec3& r : seam) best = std::min(best, (q - r).squaredNorm());
    if (best > 1e-6) return false;
  }
  return true;
}

}  // namespace

PoseEstimate localize(const std::vector<Vec3>& scan_base, const Mesh& mesh, const LocalizeSetting& s,
                      const std::vector<Vec3>& seam_points) {
  const auto t0 = std::chrono::steady_clock::now();
  PoseEstimate out;
  auto finish = [&](const std::string& reason) {
    out.reason = reason;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };

  // Model: surface samples resting on z = 0, a k-d tree, wall samples by height.
  Model model;
  double min_z = 1e9;
  for (const Vec3& v : mesh.vertices) min_z = std::min(min_z, v.z());
  Mesh rest = mesh;
  for (Vec3& v : rest.vertices) v.z() -= min_z;
  model.samples = externally_visible(rest, sample_surface(rest, s.model_spacing_m));
  if (model.samples.points.size() < 50) return finish("the model mesh is too small to sample");
  Cloud::Ptr model_cloud = to_cloud(model.samples.points);
  model.tree.setInputCloud(model_cloud);
  for (const Vec3& p : model.samples.points) {
    model.radius = std::max(model.radius, p.head<2>().norm());
    model.height = std::max(model.height, p.z());
  }
  model.walls_by_height.resize(static_cast<size_t>(model.height / kHeightBin) + 2);
  // Every third wall sample is enough to vote with.
  for (size_t k = 0; k < model.samples.points.size(); k += 3)
    if (std::abs(model.samples.normals[k].z()) < 0.5)
      model.walls_by_height[static_cast<size_t>(model.samples.points[k].z() / kHeightBin)].push_back(
          static_cast<int>(k));

  // Table plane and the object points above it, in the table frame.
  if (!find_table(scan_base, s, out.table_plane)) return finish("no table plane in the scan");
  const Iso3 T_base_table = table_frame(out.table_plane), T_table_base = T_base_table.inverse();
  std::vector<Vec3> above;
  for (const Vec3& p : scan_base) {
    const Vec3 q = T_table_base * p;
    if (q.z() < s.min_height_m || q.z() > model.height + 0.05) continue;
    if (p.head<2>().norm() < s.base_keepout_m || p.head<2>().norm() > s.reach_radius_m) continue;
    above.push_back(q);
  }
  Cloud::Ptr objects = voxelized(to_cloud(above), s.voxel_m);
  out.object_points = static_cast<int>(objects->size());
  if (objects->size() < 50) return finish("nothing stands on the table");
  std::vector<Vec3> scan;
  for (const auto& p : *objects) scan.emplace_back(p.x, p.y, p.z);

  // Normals of the object points (PCA of neighbours).
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr search(new pcl::search::KdTree<pcl::PointXYZ>);
  ne.setInputCloud(objects);
  ne.setSearchMethod(search);
  ne.setKSearch(s.normal_neighbours);
  pcl::PointCloud<pcl::Normal> normals;
  ne.compute(normals);

  // Hough voting over (x, y, yaw): a scan wall point at height z with horizontal normal direction a, matched
  // with a model wall point at the same height with normal direction b, votes for yaw = a - b (and a - b +
  // pi, for PCA normals have no sign) and the translation that puts the model point on the scan point.
  std::unordered_map<long long, int> votes;
  const int yaw_bins = static_cast<int>(std::round(360.0 / s.vote_yaw_deg));
  auto key = [&](int ix, int iy, int iw) {
    return (static_cast<long long>(ix + 100000) * 200003LL + (iy + 100000)) * 1024LL + iw;
  };
  const size_t stride = std::max<size_t>(1, scan.size() / 1500);
  for (size_t i = 0; i < scan.size(); i += stride) {
    const pcl::Normal& nn = normals[i];
    if (!std::isfinite(nn.normal_z) || std::abs(nn.normal_z) > 0.5) continue;
    const double a = std::atan2(nn.normal_y, nn.normal_x);
    const long bin = static_cast<long>(scan[i].z() / kHeightBin);
    for (long hb = bin - 1; hb <= bin + 1; ++hb) {
      if (hb < 0 || hb >= static_cast<long>(model.walls_by_height.size())) continue;
      for (int k : model.walls_by_height[static_cast<size_t>(hb)]) {
        const Vec3& m = model.samples.points[static_cast<size_t>(k)];
        const Vec3& mn = model.samples.normals[static_cast<size_t>(k)];
        const double b = std::atan2(mn.y(), mn.x());
        for (double flip : {0.0, kPi}) {
          double yaw = std::remainder(a - b + flip, 2 * kPi);
          if (yaw < 0) yaw += 2 * kPi;
          const double c = std::cos(yaw), sn = std::sin(yaw);
          const double tx = scan[i].x() - (c * m.x() - sn * m.y()),
                       ty = scan[i].y() - (sn * m.x() + c * m.y());
          const int iw = static_cast<int>(yaw / deg2rad(s.vote_yaw_deg)) % yaw_bins;
          ++votes[key(static_cast<int>(std::floor(tx / s.vote_xy_m)),
                      static_cast<int>(std::floor(ty / s.vote_xy_m)), iw)];
        }
      }
    }
  }
  if (votes.empty()) return finish("no part-like walls on the table");
  // Peaks, smoothed over the 3x3x3 neighbourhood, best first, at least a bin apart.
  std::vector<std::pair<int, long long>> ranked;
  ranked.reserve(votes.size());
  for (const auto& [k, v] : votes) ranked.emplace_back(v, k);
  std::partial_sort(ranked.begin(), ranked.begin() + std::min<size_t>(ranked.size(), 200), ranked.end(),
                    [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<Hypothesis> hyps;
  for (size_t r = 0; r < std::min<size_t>(ranked.size(), 200) && static_cast<int>(hyps.size()) < s.hypotheses;
       ++r) {
    const long long k = ranked[r].second;
    const int iw = static_cast<int>(k % 1024);
    const long long rest_k = k / 1024;
    const int iy = static_cast<int>(rest_k % 200003LL) - 100000,
              ix = static_cast<int>(rest_k / 200003LL) - 100000;
    Hypothesis h{(ix + 0.5) * s.vote_xy_m, (iy + 0.5) * s.vote_xy_m, (iw + 0.5) * deg2rad(s.vote_yaw_deg),
                 ranked[r].first};
    bool close = false;
    for (const Hypothesis& o : hyps)
      if (std::hypot(o.x - h.x, o.y - h.y) < 0.01 &&
          std::abs(std::remainder(o.yaw - h.yaw, 2 * kPi)) < deg2rad(6))
        close = true;
    if (!close) hyps.push_back(h);
  }

  // Refine every hypothesis; rank by inliers.
  pcl::KdTreeFLANN<pcl::PointXYZ> scan_tree;
  scan_tree.setInputCloud(objects);
  struct Refined {
    Iso3 P;
    IcpResult icp;
    Score score;
  };
  std::vector<Refined> refined;
  for (const Hypothesis& h : hyps) {
    const Iso3 T_table_part = planar_pose(h.x, h.y, 0.0, h.yaw);
    const IcpResult r = icp(scan, model, T_table_part.inverse(), s);
    refined.push_back({r.P, r, score(scan, scan_tree, model, r.P, s)});
  }
  // Rank by support that counts both ways: scan points explained by the model (inliers) times the share of
  // the model's visible surface the scan confirms (coverage). A clamp can lend inliers to a wrong pose, but
  // it rarely shows the faces that pose predicts.
  auto support = [](const Score& sc) { return sc.inliers * sc.coverage; };
  std::sort(refined.begin(), refined.end(),
            [&](const Refined& a, const Refined& b) { return support(a.score) > support(b.score); });
  if (refined.empty()) return finish("part not found");
  const Refined& best = refined.front();

  // Ambiguity: the best distinct pose that is not the same weld by the part's symmetry.
  const Iso3 T_best = best.P.inverse();
  for (size_t k = 1; k < refined.size(); ++k) {
    const Iso3 D = best.P * refined[k].P.inverse();  // part frame to part frame
    const double dt = D.translation().norm(), dr = Eigen::AngleAxisd(D.linear()).angle();
    // The same pose found twice, or a shallower minimum next to it (ICP from a coarse peak): not a rival.
    if (dt < 0.008 && dr < deg2rad(5)) continue;
    if (self_similar(model, D)) continue;
    // Seam points given in the mesh's own frame; the model was lifted by -min_z.
    const Iso3 lift = make_transform(Vec3(0, 0, -min_z), Mat3::Identity());
    if (same_seams(seam_points, lift.inverse() * D * lift)) continue;
    out.ambiguity = std::max(out.ambiguity, support(refined[k].score) / std::max(1e-9, support(best.score)));
  }

  const Iso3 T_table_part = T_best;
  // The mesh was shifted up by -min_z to rest on z = 0; undo it in the part frame.
  const Iso3 shift = make_transform(Vec3(0, 0, -min_z), Mat3::Identity());
  out.T_base_part = orthonormalized(T_base_table * T_table_part * shift);
  out.fitness = best.score.region ? static_cast<double>(best.score.inliers) / best.score.region : 0.0;
  out.rmse_m = best.score.rmse;
  out.coverage = best.score.coverage;
  out.converged = best.icp.converged;
  out.iterations = best.icp.iterations;
  out.inliers = best.score.inliers;
  if (out.coverage < s.min_coverage)
    return finish("part not found: the best match covers too little of the model");
  if (out.rmse_m > s.max_rmse_m || out.fitness < s.min_fitness)
    return finish("the part fits the scan poorly");
  if (out.ambiguity >= s.ambiguity_ratio) return finish("ambiguous: a different pose fits almost as well");
  out.found = true;
  return finish("");
}

}  // namespace weldtwin
