#include "app/mount_file.hpp"

#include <cmath>
#include <stdexcept>

#include "app/json_file.hpp"
#include "core/error.hpp"

namespace weldtwin {

Iso3 mount_offset(const std::vector<double>& mm, const std::vector<double>& deg) {
  Iso3 d = Iso3::Identity();
  if (!mm.empty()) d.translate(1e-3 * Vec3(mm.at(0), mm.at(1), mm.at(2)));
  if (!deg.empty())
    d.rotate(Eigen::AngleAxisd(deg2rad(deg.at(2)), Vec3::UnitZ()) *
             Eigen::AngleAxisd(deg2rad(deg.at(1)), Vec3::UnitY()) *
             Eigen::AngleAxisd(deg2rad(deg.at(0)), Vec3::UnitX()));
  return d;
}

Vec3 rpy_deg(const Mat3& R) {
  const Vec3 ypr = R.eulerAngles(2, 1, 0);
  Vec3 rpy(ypr[2], ypr[1], ypr[0]);
  // eulerAngles keeps the first angle in [0, pi]: fold to the small-angle branch.
  if (std::abs(rpy[0]) > kPi / 2)
    rpy = Vec3(rpy[0] - kPi * (rpy[0] > 0 ? 1 : -1), kPi - rpy[1], rpy[2] - kPi);
  for (int i = 0; i < 3; ++i) rpy[i] = std::remainder(rpy[i], 2 * kPi);
  return rpy * 180.0 / kPi;
}

nlohmann::json mount_correction_json(const MountCorrection& mount) {
  const Vec3 t = mount.correction.translation(), r = rpy_deg(mount.correction.linear());
  nlohmann::json j;
  j["lidar_link"] = mount.lidar_link;
  j["correction"] = {{"xyz_m", {t.x(), t.y(), t.z()}}, {"rpy_deg", {r.x(), r.y(), r.z()}}};
  j["note"] = "the LiDAR link's URDF origin, right-multiplied by this correction, is the calibrated mount";
  return j;
}

MountCorrection read_mount_file(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "LiDAR mount");
  try {
    MountCorrection m;
    m.lidar_link = j.at("lidar_link").get<std::string>();
    if (m.lidar_link.empty()) throw std::runtime_error("lidar_link is empty");
    const auto xyz = j.at("correction").at("xyz_m").get<std::vector<double>>();
    const auto rpy = j.at("correction").at("rpy_deg").get<std::vector<double>>();
    if (xyz.size() != 3 || rpy.size() != 3) throw std::runtime_error("xyz_m and rpy_deg take three numbers");
    for (double v : xyz)
      if (!std::isfinite(v)) throw std::runtime_error("xyz_m holds a number that is not finite");
    for (double v : rpy)
      if (!std::isfinite(v)) throw std::runtime_error("rpy_deg holds a number that is not finite");
    m.correction = mount_offset({1e3 * xyz[0], 1e3 * xyz[1], 1e3 * xyz[2]}, rpy);
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw input_error(path, std::string("not a mount JSON of weldtwin calibrate: ") + e.what());
  } catch (const std::runtime_error& e) {
    throw input_error(path, std::string("not a mount JSON of weldtwin calibrate: ") + e.what());
  }
}

}  // namespace weldtwin
