#include "perception/pose_error.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.hpp"

namespace weldtwin {
namespace {

// Distance from p (base frame) to the nearest seam of the part whose frame is T_part_base from the base's.
double distance_to(const PartSpec& part, const Iso3& T_part_base, const Vec3& p) {
  const Vec3 q = T_part_base * p;
  double best = std::numeric_limits<double>::infinity();
  for (const Seam& seam : part.seams) best = std::min(best, seam.distance_to(q));
  return best;
}

// Points along the seams every 0.5 mm, ends included.
std::vector<Vec3> stations(const PartSpec& part, const Iso3& T) {
  std::vector<Vec3> out;
  for (const Vec3& p : part.seam_points(5e-4)) out.push_back(T * p);
  return out;
}

}  // namespace

int z_symmetry_order(const Mesh& mesh, double tolerance_m) {
  // A vertex maps onto the surface if it lands within tolerance of some face; brute force over faces is
  // fine for the few thousand triangles of a part.
  auto on_surface = [&](const Vec3& p) {
    for (const Eigen::Vector3i& f : mesh.faces) {
      const Vec3 &a = mesh.vertices[static_cast<size_t>(f[0])], &b = mesh.vertices[static_cast<size_t>(f[1])],
                 &c = mesh.vertices[static_cast<size_t>(f[2])];
      Vec3 n = (b - a).cross(c - a);
      const double area2 = n.norm();
      if (area2 <= 0) continue;
      n /= area2;
      const double h = (p - a).dot(n);
      if (std::abs(h) > tolerance_m) continue;
      const Vec3 q = p - h * n;  // projection into the face's plane: inside the triangle?
      const double u = (b - a).cross(q - a).dot(n), v = (c - b).cross(q - b).dot(n),
                   w = (a - c).cross(q - c).dot(n);
      const double edge = tolerance_m * std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
      if (u >= -edge && v >= -edge && w >= -edge) return true;
    }
    return false;
  };
  for (int order = 8; order >= 2; --order) {
    const Mat3 R = Eigen::AngleAxisd(2 * kPi / order, Vec3::UnitZ()).toRotationMatrix();
    bool all = true;
    for (size_t i = 0; i < mesh.vertices.size() && all; i += 1 + mesh.vertices.size() / 400)
      all = on_surface(R * mesh.vertices[i]);
    if (all) return order;
  }
  return 1;
}

PoseError pose_error(const PartSpec& part, const Iso3& estimate, const Iso3& truth, int symmetry_order) {
  PoseError e;
  const Iso3 truth_inverse = truth.inverse(), estimate_inverse = estimate.inverse();
  double sum = 0.0;
  const std::vector<Vec3> est = stations(part, estimate), tru = stations(part, truth);
  for (const Vec3& p : est) {
    const double d = distance_to(part, truth_inverse, p);
    e.seam_max_m = std::max(e.seam_max_m, d);
    sum += d;
  }
  e.seam_mean_m = est.empty() ? 0.0 : sum / static_cast<double>(est.size());
  for (const Vec3& p : tru) e.seam_max_m = std::max(e.seam_max_m, distance_to(part, estimate_inverse, p));
  // Seams that are all full circles about one vertical axis weld the same for any turn about it: then only
  // the tilt of that axis counts.
  bool circles = !part.seams.empty();
  for (const Seam& s : part.seams)
    circles = circles && s.kind == Seam::Kind::kArc && std::abs(s.axis.z()) > 1 - 1e-9 &&
              std::abs(std::abs(s.sweep_rad) - 2 * kPi) < 1e-6 &&
              (s.center - part.seams.front().center).head<2>().norm() < 1e-6;
  if (circles) {
    const Vec3 a = estimate.linear().col(2), b = truth.linear().col(2);
    e.rotation_rad = std::atan2(a.cross(b).norm(), a.dot(b));
    const Vec3 c = part.seams.front().center;
    e.origin_m = (estimate * c - truth * c).norm();
    return e;
  }
  e.rotation_rad = e.origin_m = std::numeric_limits<double>::infinity();
  for (int k = 0; k < std::max(1, symmetry_order); ++k) {
    const Iso3 t = truth * planar_pose(0, 0, 0, 2 * kPi * k / std::max(1, symmetry_order));
    const double angle = Eigen::AngleAxisd(t.linear().transpose() * estimate.linear()).angle();
    if (angle < e.rotation_rad) {
      e.rotation_rad = angle;
      e.origin_m = (t.translation() - estimate.translation()).norm();
    }
  }
  return e;
}

double seam_distance_m(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  auto farthest = [](const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
    double worst2 = 0.0;
    for (const Vec3& p : from) {
      double best2 = std::numeric_limits<double>::infinity();
      for (const Vec3& q : to) best2 = std::min(best2, (p - q).squaredNorm());
      worst2 = std::max(worst2, best2);
    }
    return worst2;
  };
  if (a.empty() || b.empty()) return std::numeric_limits<double>::infinity();
  return std::sqrt(std::max(farthest(a, b), farthest(b, a)));
}

SampleTruth read_sample_truth(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw input_error(file, "cannot open the truth file");
  SampleTruth t;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    for (size_t r = 0; r < 4; ++r)
      for (size_t c = 0; c < 4; ++c)
        t.T_base_part.matrix()(static_cast<long>(r), static_cast<long>(c)) = j.at("T_base_part").at(r).at(c);
    for (const auto& s : j.at("seams_part")) {
      Seam seam;
      seam.name = "seam" + std::to_string(t.part.seams.size());
      for (int k = 0; k < 3; ++k) {
        seam.start[k] = s.at("start").at(static_cast<size_t>(k));
        seam.end[k] = s.at("end").at(static_cast<size_t>(k));
      }
      // A full circle about a vertical axis (a round tube's foot): its centre and radius.
      if (s.contains("circle_radius")) {
        seam.kind = Seam::Kind::kArc;
        seam.radius_m = s.at("circle_radius");
        for (int k = 0; k < 3; ++k) seam.center[k] = s.at("centre").at(static_cast<size_t>(k));
        seam.axis = Vec3::UnitZ();
        seam.sweep_rad = 2 * kPi;
      }
      t.part.seams.push_back(seam);
    }
  } catch (const nlohmann::json::exception& e) {
    throw input_error(file, std::string("malformed truth: ") + e.what());
  }
  t.part.source = file;
  return t;
}

}  // namespace weldtwin
