#include "app/calibrate_command.hpp"

#include <tinyxml.h>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "app/json_file.hpp"
#include "app/mount_file.hpp"
#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "core/scenes.hpp"
#include "hw/scan_source.hpp"
#include "perception/mesh_io.hpp"
#include "perception/mount_calibration.hpp"
#include "pipeline/outcome.hpp"
#include "sim/cell_layout.hpp"

namespace weldtwin {
namespace {

// Writes `urdf` again with the origin of the joint whose child is `link` replaced by `origin`; every other
// element as it was (parsed and written by TinyXML, which urdfdom reads with).
// Writes the robot's URDF (`urdf_xml`, read from `source`) with the joint of `link` moved to `origin`.
// Every mesh the URDF names, rewritten as its absolute path: the file written elsewhere still finds them.
void absolute_mesh_paths(TiXmlElement* robot, const std::string& source,
                         const std::vector<std::string>& dirs) {
  for (TiXmlElement* l = robot->FirstChildElement("link"); l; l = l->NextSiblingElement("link"))
    for (const char* kind : {"visual", "collision"})
      for (TiXmlElement* e = l->FirstChildElement(kind); e; e = e->NextSiblingElement(kind)) {
        TiXmlElement* g = e->FirstChildElement("geometry");
        TiXmlElement* mesh = g ? g->FirstChildElement("mesh") : nullptr;
        if (!mesh || !mesh->Attribute("filename")) continue;
        const std::string file = mesh_file(mesh->Attribute("filename"), source,
                                           l->Attribute("name") ? l->Attribute("name") : "", dirs);
        mesh->SetAttribute("filename", std::filesystem::absolute(file).lexically_normal().string());
      }
}

void write_urdf_with_mount(const std::string& urdf_xml, const std::string& source,
                           const std::vector<std::string>& package_dirs, const std::string& link,
                           const Iso3& origin, const std::string& out) {
  TiXmlDocument doc;
  doc.Parse(urdf_xml.c_str());
  if (doc.Error()) throw input_error(source, "cannot be read as XML");
  TiXmlElement* robot = doc.FirstChildElement("robot");
  if (robot) absolute_mesh_paths(robot, source, package_dirs);
  for (TiXmlElement* j = robot ? robot->FirstChildElement("joint") : nullptr; j;
       j = j->NextSiblingElement("joint")) {
    const TiXmlElement* child = j->FirstChildElement("child");
    if (!child || !child->Attribute("link") || link != child->Attribute("link")) continue;
    TiXmlElement* o = j->FirstChildElement("origin");
    if (!o) o = j->InsertEndChild(TiXmlElement("origin"))->ToElement();
    const Vec3 t = origin.translation(), r = rpy_deg(origin.linear()) * kPi / 180.0;
    char xyz[128], rpy[128];
    std::snprintf(xyz, sizeof xyz, "%.9g %.9g %.9g", t.x(), t.y(), t.z());
    std::snprintf(rpy, sizeof rpy, "%.9g %.9g %.9g", r.x(), r.y(), r.z());
    o->SetAttribute("xyz", xyz);
    o->SetAttribute("rpy", rpy);
    if (!doc.SaveFile(out.c_str())) throw input_error(out, "cannot be written");
    return;
  }
  throw input_error(source, "no joint with child link '" + link + "'");
}

}  // namespace

int run_calibrate(const CalibrateCommand& cmd) {
  if (cmd.out.empty()) throw InputError("calibrate: --out (the mount JSON to write) is needed");
  for (const auto* v : {&cmd.mount_error_mm, &cmd.mount_error_deg})
    if (!v->empty() && v->size() != 3)
      throw InputError("--mount-error-mm / --mount-error-deg take three numbers");
  const bool twin_error = !cmd.mount_error_mm.empty() || !cmd.mount_error_deg.empty();
  if (twin_error && cmd.source != "sim")
    throw InputError("--mount-error-* is for the twin's sweep (--source sim) only");
  const CellSpec cell = CellSpec::load(cmd.cell.empty() ? scene_file("cells/calibration.yaml") : cmd.cell);
  const PartSpec part = PartSpec::load(cell.part_spec);
  const RobotModel robot = load_cell_robot(cell);
  const Mesh box = load_mesh(part.mesh_path);
  const MountCalibrationSetting setting = MountCalibrationSetting::for_box(box);
  const CellLayout layout = make_layout(cell, part, {});
  const Iso3 error = mount_offset(cmd.mount_error_mm, cmd.mount_error_deg);
  const std::string lidar_link = SweepOptions().lidar_link;
  const RobotModel real = twin_error ? robot.with_mount_offset(lidar_link, error) : robot;
  const MujocoWorld world(cell, part, real, layout);
  const SweepProgram program = SweepProgram::load(cell.sweep_program, real);
  SimScanInputs sim;
  sim.world = &world;
  sim.robot = &real;
  sim.program = &program;
  sim.lidar.apply(cell.lidar_overrides, cell.source);
  if (cmd.seed) sim.lidar.seed = *cmd.seed;
  const auto source = make_scan_source(cmd.source, robot, sim);
  if (!cmd.quiet)
    std::fprintf(stderr, "calibrate: a sweep of the calibration cell from %s\n", source->describe().c_str());
  const ScanLog log = source->acquire();
  const MountCalibration cal = calibrate_mount(log, robot, setting, cmd.source);

  const Vec3 t = cal.delta.translation(), r = rpy_deg(cal.delta.linear());
  nlohmann::json j = mount_correction_json({log.lidar_frame, cal.delta});
  j["box"] = {{"x_m", cal.T_base_box.translation().x()},
              {"y_m", cal.T_base_box.translation().y()},
              {"yaw_deg", rad2deg(std::atan2(cal.T_base_box.linear()(1, 0), cal.T_base_box.linear()(0, 0)))}};
  j["rms_mm"] = 1e3 * cal.rms_m;
  j["table_points"] = cal.table_points;
  j["box_points"] = cal.box_points;
  j["converged"] = cal.converged;
  if (twin_error) {
    const double dt = (cal.delta.translation() - error.translation()).norm();
    const double dr = rad2deg(Eigen::AngleAxisd(cal.delta.linear().transpose() * error.linear()).angle());
    j["twin_check"] = {{"translation_error_mm", 1e3 * dt}, {"rotation_error_deg", dr}};
  }
  write_json_file(cmd.out, j);
  if (!cmd.urdf_out.empty()) {
    const RobotLink& l = robot.links()[static_cast<size_t>(robot.require_link(log.lidar_frame))];
    write_urdf_with_mount(cell_robot_urdf(cell), cell.robot_urdf, cell.robot_package_dirs, log.lidar_frame,
                          l.T_parent_joint * cal.delta, cmd.urdf_out);
    if (!cmd.quiet)
      std::fprintf(stderr, "calibrate: the URDF with the calibrated mount: %s\n", cmd.urdf_out.c_str());
  }
  std::printf(
      "mount correction (%.3f, %.3f, %.3f) mm, (%.4f, %.4f, %.4f) deg; rms %.2f mm over %d table and %d box "
      "points -> %s\n",
      1e3 * t.x(), 1e3 * t.y(), 1e3 * t.z(), r.x(), r.y(), r.z(), 1e3 * cal.rms_m, cal.table_points,
      cal.box_points, cmd.out.c_str());
  if (twin_error)
    std::printf("twin check: the mount error put in was recovered within %.3f mm and %.4f deg\n",
                j["twin_check"]["translation_error_mm"].get<double>(),
                j["twin_check"]["rotation_error_deg"].get<double>());
  if (!cal.converged || cal.rms_m > 0.004) {
    std::printf("UNTRUSTWORTHY: %s\n",
                !cal.converged ? "the fit did not converge" : "residuals above 4 mm rms");
    return kExitUntrustworthy;
  }
  return kExitPassed;
}

}  // namespace weldtwin
