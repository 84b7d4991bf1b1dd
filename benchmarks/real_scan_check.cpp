#include "benchmarks/real_scan_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "perception/localizer.hpp"
#include "perception/mesh_io.hpp"
#include "perception/paper_localizer.hpp"
#include "pipeline/weld_pipeline.hpp"

namespace weldtwin {
namespace {

constexpr double kSplitHalfBar = 0.0005;  // the repeatability target [m]

struct Nominal {
  std::string mesh;
  Vec3 placed_xyz = Vec3::Zero(), placed_rpy = Vec3::Zero();
  Vec3 cal_xyz = Vec3::Zero(), cal_rpy = Vec3::Zero();  ///< expected minus measured
};

Vec3 vec3(const nlohmann::json& j, const char* key) {
  return Vec3(j.at(key).at(0).get<double>(), j.at(key).at(1).get<double>(), j.at(key).at(2).get<double>());
}

Nominal read_nominal(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw input_error(file, "cannot open the placement file");
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    Nominal n;
    const std::string m = j.at("part_mesh").get<std::string>();
    n.mesh = m.substr(0, m.find(' '));
    n.placed_xyz = vec3(j, "placed_T_base_part_xyz_m");
    n.placed_rpy = vec3(j, "placed_rpy_rad");
    n.cal_xyz = vec3(j, "paper_lidar_calibration_difference_xyz_m");
    n.cal_rpy = vec3(j, "paper_lidar_calibration_difference_rpy_rad");
    return n;
  } catch (const nlohmann::json::exception& e) {
    throw input_error(file, std::string("malformed placement: ") + e.what());
  }
}

double min_z(const Mesh& m) {
  double z = 1e9;
  for (const Vec3& v : m.vertices) z = std::min(z, v.z());
  return z;
}

// (roll, pitch, yaw) of R, URDF's convention (R = Rz Ry Rx).
Vec3 rpy(const Mat3& R) {
  return Vec3(std::atan2(R(2, 1), R(2, 2)), std::asin(std::clamp(-R(2, 0), -1.0, 1.0)),
              std::atan2(R(1, 0), R(0, 0)));
}

double seam_distance(const Iso3& A, const Iso3& B, const std::vector<Vec3>& seams) {
  double worst = 0.0;
  for (const Vec3& s : seams) worst = std::max(worst, (A * s - B * s).norm());
  return worst;
}

void print_against_placement(const char* what, const Iso3& T, const Nominal& n) {
  const Vec3 p = T.translation(), r = rpy(T.linear());
  const Vec3 d = n.placed_xyz - p, dr = n.placed_rpy - r;
  const Vec3 dc = n.placed_xyz - (p + n.cal_xyz), drc = n.placed_rpy - (r + n.cal_rpy);
  auto wrap = [](double a) { return rad2deg(std::remainder(a, 2 * kPi)); };
  std::printf(
      "  %-6s at (%.4f, %.4f, %.4f) m, yaw %.2f deg; placed minus found: (%+.1f, %+.1f, %+.1f) mm %.1f mm, "
      "yaw "
      "%+.2f deg; after the calibration difference: (%+.1f, %+.1f, %+.1f) mm %.1f mm, roll %+.2f pitch %+.2f "
      "yaw %+.2f deg\n",
      what, p.x(), p.y(), p.z(), rad2deg(r.z()), 1e3 * d.x(), 1e3 * d.y(), 1e3 * d.z(), 1e3 * d.norm(),
      wrap(dr.z()), 1e3 * dc.x(), 1e3 * dc.y(), 1e3 * dc.z(), 1e3 * dc.norm(), wrap(drc.x()), wrap(drc.y()),
      wrap(drc.z()));
}

}  // namespace

int check_real_scans(const std::string& dir, const std::string& part_spec,
                     const std::vector<std::string>& impostor_meshes, bool paper) {
  namespace fs = std::filesystem;
  const Nominal nominal = read_nominal((fs::path(dir) / "nominal.json").string());
  const std::string mesh_file = (fs::path(dir) / nominal.mesh).string();
  const Mesh mesh = load_mesh(mesh_file);
  // The seams of the part spec, in the directory mesh's frame (the two frames differ by a lift in z).
  const PartSpec part = PartSpec::load(part_spec);
  const double lift = min_z(mesh) - min_z(load_mesh(part.mesh_path));
  std::vector<Vec3> seams = part.seam_points(0.001);
  for (Vec3& s : seams) s.z() += lift;
  const PreparedPart prepared(mesh);
  std::vector<fs::path> scans;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("scan", 0) == 0 &&
        (e.path().extension() == ".pcd" || e.path().extension() == ".ply"))
      scans.push_back(e.path());
  std::sort(scans.begin(), scans.end());
  int failed = 0;
  for (const fs::path& scan : scans) {
    const std::vector<Vec3> cloud = read_cloud(scan.string());
    const PoseEstimate ours = localize(cloud, prepared, localize_setting_for(part), seams);
    std::printf(
        "real %s (%zu points): ours %s in %.2f s, seam error bound %.2f mm [beyond edges along %.0f mm, "
        "one edge's %.2f of %.0f mm]%s%s\n",
        scan.filename().c_str(), cloud.size(), ours.found ? "found" : "refused", ours.seconds,
        1e3 * ours.seam_error_bound_m, 1e3 * ours.beyond_extent_m, ours.beyond_line_share,
        1e3 * ours.beyond_line_length_m, ours.found ? "" : ": ", ours.reason.c_str());
    print_against_placement("ours", ours.T_base_part, nominal);
    // Split-half repeatability: interleaved halves, each localized alone.
    std::vector<Vec3> half[2];
    for (size_t i = 0; i < cloud.size(); ++i) half[i % 2].push_back(cloud[i]);
    const PoseEstimate a = localize(half[0], prepared, localize_setting_for(part), seams);
    const PoseEstimate b = localize(half[1], prepared, localize_setting_for(part), seams);
    const double split = seam_distance(a.T_base_part, b.T_base_part, seams);
    std::printf(
        "  split halves: %s / %s, seams %.3f mm apart (bar %.1f mm); each half from the whole: %.3f / %.3f "
        "mm\n",
        a.found ? "found" : a.reason.c_str(), b.found ? "found" : b.reason.c_str(), 1e3 * split,
        1e3 * kSplitHalfBar, 1e3 * seam_distance(a.T_base_part, ours.T_base_part, seams),
        1e3 * seam_distance(b.T_base_part, ours.T_base_part, seams));
    if (paper) {
      const PoseEstimate p = localize_paper(cloud, mesh);
      std::printf("  paper's pipeline in %.2f s, seams %.2f mm from ours\n", p.seconds,
                  1e3 * seam_distance(p.T_base_part, ours.T_base_part, seams));
      print_against_placement("paper", p.T_base_part, nominal);
    }
    int false_accepts = 0;
    for (const std::string& other : impostor_meshes) {
      const PoseEstimate w = localize(cloud, load_mesh(other));
      false_accepts += w.found;
      std::printf("  %s sought: %s%s%s\n", fs::path(other).filename().c_str(),
                  w.found ? "FALSE ACCEPT" : "refused", w.found ? "" : ": ", w.reason.c_str());
    }
    failed += !ours.found || false_accepts > 0 || !(split <= kSplitHalfBar);
  }
  return failed;
}

}  // namespace weldtwin
