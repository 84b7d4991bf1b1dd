#include "perception/mount_calibration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "perception/scan_assembly.hpp"

namespace weldtwin {
namespace {

constexpr int kParams = 9;  // mount rotation vector (3), mount translation (3), box x, y, yaw
using Params = Eigen::Matrix<double, kParams, 1>;

struct Sample {
  Iso3 A;  ///< base <- URDF lidar frame, at the sample's time
  Vec3 p;  ///< the point in the lidar frame
};

Iso3 mount(const Params& x) {
  Iso3 d = Iso3::Identity();
  d.translate(x.segment<3>(3));
  const Vec3 w = x.head<3>();
  if (w.norm() > 0) d.rotate(Eigen::AngleAxisd(w.norm(), w.normalized()));
  return d;
}

Iso3 box_pose(const Params& x) {
  Iso3 b = Iso3::Identity();
  b.translate(Vec3(x[6], x[7], 0.0));
  b.rotate(Eigen::AngleAxisd(x[8], Vec3::UnitZ()));
  return b;
}

// What a point is taken to lie on: the table (face -1) or a box face (0..4: +x, -x, +y, -y, top).
struct Assoc {
  size_t sample = 0;
  int face = -1;
};

double residual(const Sample& s, int face, const Iso3& delta, const Iso3& box_inv, const Vec3& size) {
  const Vec3 pb = s.A * (delta * s.p);
  if (face < 0) return pb.z();
  const Vec3 q = box_inv * pb;
  switch (face) {
    case 0:
      return q.x() - 0.5 * size.x();
    case 1:
      return -q.x() - 0.5 * size.x();
    case 2:
      return q.y() - 0.5 * size.y();
    case 3:
      return -q.y() - 0.5 * size.y();
    default:
      return q.z() - size.z();
  }
}

}  // namespace

MountCalibrationSetting MountCalibrationSetting::for_box(const Mesh& box) {
  MountCalibrationSetting s;
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const Vec3& v : box.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  s.box_size_m = hi - lo;
  return s;
}

MountCalibration calibrate_mount(const ScanLog& log, const RobotModel& robot,
                                 const MountCalibrationSetting& setting, const std::string& source) {
  const int lidar = robot.link_index(log.lidar_frame);
  if (lidar < 0) throw input_error(source, "the robot has no link '" + log.lidar_frame + "'");
  // The usable samples, evenly thinned, with the URDF's lidar pose at their time.
  size_t valid = 0;
  for (const LidarSample& s : log.samples) valid += s.range_m > 0 && s.quality > 0;
  const size_t stride = std::max<size_t>(1, valid / static_cast<size_t>(setting.max_points));
  std::vector<Sample> samples;
  size_t k = 0;
  for (const LidarSample& s : log.samples) {
    if (!(s.range_m > 0 && s.quality > 0) || (k++ % stride) != 0) continue;
    JointVector q;
    if (!interpolate_joints(log.joints, s.t_s, q)) continue;
    samples.push_back({robot.forward_kinematics(q, lidar),
                       Vec3(s.range_m * std::cos(s.angle_rad), s.range_m * std::sin(s.angle_rad), 0.0)});
  }
  const Vec3 size = setting.box_size_m;

  // The box, roughly: the points at its top's height, their centroid and principal axis.
  Params x = Params::Zero();
  {
    std::vector<Eigen::Vector2d> top;
    for (const Sample& s : samples) {
      const Vec3 pb = s.A * s.p;
      if (std::abs(pb.z() - size.z()) < 0.015 && pb.head<2>().norm() > setting.keep_out_radius_m)
        top.emplace_back(pb.x(), pb.y());
    }
    if (top.size() < 100)
      throw input_error(source, "no box top at " + std::to_string(size.z()) + " m in the sweep (" +
                                    std::to_string(top.size()) +
                                    " points): is the calibration box on the table?");
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : top) c += p;
    c /= static_cast<double>(top.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& p : top) cov += (p - c) * (p - c).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d major = eig.eigenvectors().col(1);
    x[6] = c.x();
    x[7] = c.y();
    x[8] = std::atan2(major.y(), major.x());
  }

  MountCalibration out;
  std::vector<Assoc> used;
  std::vector<double> r;
  for (int round = 0; round < setting.rounds; ++round) {
    // Associate: table points away from the box, box points to their nearest face; trim at 3 robust sigmas.
    const Iso3 delta = mount(x), box_inv = box_pose(x).inverse();
    used.clear();
    for (size_t i = 0; i < samples.size(); ++i) {
      const Vec3 pb = samples[i].A * (delta * samples[i].p);
      if (pb.head<2>().norm() < setting.keep_out_radius_m) continue;
      const Vec3 q = box_inv * pb;
      const double ox = std::abs(q.x()) - 0.5 * size.x(), oy = std::abs(q.y()) - 0.5 * size.y();
      if (ox > setting.near_m || oy > setting.near_m) {  // beside the box
        if (std::abs(pb.z()) < setting.near_m) used.push_back({i, -1});
        continue;
      }
      if (q.z() < setting.near_m || q.z() > size.z() + setting.near_m) continue;
      const double d[5] = {std::abs(q.x() - 0.5 * size.x()), std::abs(q.x() + 0.5 * size.x()),
                           std::abs(q.y() - 0.5 * size.y()), std::abs(q.y() + 0.5 * size.y()),
                           std::abs(q.z() - size.z())};
      const int face = static_cast<int>(std::min_element(d, d + 5) - d);
      if (d[face] < setting.near_m) used.push_back({i, face});
    }
    r.resize(used.size());
    for (size_t j = 0; j < used.size(); ++j)
      r[j] = residual(samples[used[j].sample], used[j].face, delta, box_inv, size);
    std::vector<double> a(r.size());
    for (size_t j = 0; j < r.size(); ++j) a[j] = std::abs(r[j]);
    std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2), a.end());
    const double sigma = std::max(2e-4, 1.4826 * (a.empty() ? 0.0 : a[a.size() / 2]));
    // The trim starts at the association window and narrows to 3 sigma over the first half of the rounds: the
    // rough box may sit a centimetre off (its top's centroid leans towards where the LiDAR saw more of it),
    // and the table's points, the most, would otherwise set a sigma that cuts the box's sides away for good.
    const double anneal = std::max(0.0, 1.0 - 2.0 * round / std::max(1, setting.rounds));
    const double trim = std::max(3 * sigma, anneal * setting.near_m);
    std::vector<Assoc> kept;
    for (size_t j = 0; j < used.size(); ++j)
      if (std::abs(r[j]) < trim) kept.push_back(used[j]);
    used.swap(kept);
    out.table_points = out.box_points = 0;
    for (const Assoc& u : used) ++(u.face < 0 ? out.table_points : out.box_points);
    if (out.table_points < 500 || out.box_points < 500)
      throw input_error(source, "the sweep shows " + std::to_string(out.table_points) + " table and " +
                                    std::to_string(out.box_points) +
                                    " box points near where they should be: too few to calibrate from (is "
                                    "the calibration box on the "
                                    "table?)");

    // Gauss-Newton steps on these associations (central differences).
    for (int step = 0; step < 3; ++step) {
      auto residuals = [&](const Params& p, Eigen::VectorXd& res) {
        const Iso3 d = mount(p), bi = box_pose(p).inverse();
        res.resize(static_cast<Eigen::Index>(used.size()));
        for (size_t j = 0; j < used.size(); ++j)
          res[static_cast<Eigen::Index>(j)] = residual(samples[used[j].sample], used[j].face, d, bi, size);
      };
      Eigen::VectorXd r0, rp, rm;
      residuals(x, r0);
      Eigen::MatrixXd J(r0.size(), kParams);
      for (int c = 0; c < kParams; ++c) {
        Params xp = x, xm = x;
        xp[c] += 1e-6;
        xm[c] -= 1e-6;
        residuals(xp, rp);
        residuals(xm, rm);
        J.col(c) = (rp - rm) / 2e-6;
      }
      Eigen::Matrix<double, kParams, kParams> H = J.transpose() * J;
      H.diagonal() *= 1.0 + 1e-9;
      const Params dx = H.ldlt().solve(-J.transpose() * r0);
      x += dx;
      out.rms_m = std::sqrt(r0.squaredNorm() / static_cast<double>(r0.size()));
      out.converged = dx.head<6>().cwiseAbs().maxCoeff() < 1e-7;
    }
  }
  out.delta = mount(x);
  out.T_base_box = box_pose(x);
  return out;
}

}  // namespace weldtwin
