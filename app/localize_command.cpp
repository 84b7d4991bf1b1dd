#include "app/localize_command.hpp"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>

#include "app/json_file.hpp"
#include "app/pose_file.hpp"
#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "core/scenes.hpp"
#include "perception/localizer.hpp"
#include "perception/mesh_io.hpp"
#include "perception/paper_localizer.hpp"
#include "pipeline/outcome.hpp"

namespace weldtwin {

void describe_weldtwin(CLI::App& app) {
  app.description(
      "weldtwin: find a clamped part with a wrist-mounted 2D LiDAR, plan its welds and check them in a "
      "MuJoCo "
      "digital twin of the cell.");
  try {
    app.footer("Scenes (the default cells, parts, robots and sweeps): " + scenes_dir() +
               " (WELDTWIN_SCENES names another).");
  } catch (const InputError& e) {
    app.footer(std::string("Scenes: ") + e.what());
  }
}

CLI::App* add_localize_command(CLI::App& app, LocalizeCommand& cmd) {
  CLI::App* lc =
      app.add_subcommand("localize", "Find the part (its mesh) in a base-frame cloud of a table scene");
  lc->add_option("--model", cmd.model,
                 "part mesh (STL, PLY, OBJ), part frame (default: the --part spec's model)");
  lc->add_option("--scan", cmd.scan, "cloud (PCD or PLY), base frame")->required();
  lc->add_option("--roi", cmd.roi_text, "optional crop box xmin,ymin,zmin,xmax,ymax,zmax [m] (not needed)");
  lc->add_option("--units", cmd.units, "mesh units: m (default) or mm");
  lc->add_option(
      "--part", cmd.part,
      "part spec (its model is the mesh sought, unless --model is given): poses that put the seams on "
      "the same places are equivalent");
  lc->add_option(
        "--method", cmd.method,
        "ours (default), or paper: the published PassThrough/RANSAC/point-to-point ICP pipeline, kept "
        "as the baseline (it has no verdict and answers even when wrong)")
      ->check(CLI::IsMember({"ours", "paper"}));
  lc->add_option("--out", cmd.out, "pose JSON to write")->required();
  lc->add_option("--table-top-z-mm", cmd.table_top_z_mm,
                 "where the cell's table top is (the plane z = this in the base frame) [mm]: a scan that "
                 "shows the table elsewhere is refused, as assembled through a LiDAR mount that is off "
                 "(default: not checked)");
  lc->add_option("--part-cache", cmd.part_cache,
                 "folder where the prepared part (its samples, visibility, edges, footprint) is kept between "
                 "runs, so that the next localization of the same part skips preparing it (default: " +
                     (default_part_cache_dir().empty() ? std::string("none") : default_part_cache_dir()) +
                     "; WELDTWIN_PART_CACHE names another, or off)");
  lc->add_flag("--no-part-cache", cmd.no_part_cache, "prepare the part anew and keep nothing");
  lc->add_flag("-q,--quiet", cmd.quiet, "no progress line");
  return lc;
}

std::string default_part_cache_dir() {
  auto env = [](const char* name) {
    const char* v = std::getenv(name);
    return std::string(v ? v : "");
  };
  const std::string named = env("WELDTWIN_PART_CACHE");
  if (named == "off") return "";
  if (!named.empty()) return named;
  if (!env("XDG_CACHE_HOME").empty()) return env("XDG_CACHE_HOME") + "/weldtwin/parts";
  if (!env("HOME").empty()) return env("HOME") + "/.cache/weldtwin/parts";
  return "";
}

int run_localize(LocalizeCommand cmd) {
  const auto started =
      std::chrono::steady_clock::now();  // the files' reading and the part's making count too
  for (size_t a = 0, b; a < cmd.roi_text.size(); a = b + 1) {
    b = cmd.roi_text.find(',', a);
    if (b == std::string::npos) b = cmd.roi_text.size();
    try {
      cmd.roi.push_back(std::stod(cmd.roi_text.substr(a, b - a)));
    } catch (const std::exception&) {
      throw InputError("--roi: '" + cmd.roi_text + "' is not six numbers");
    }
  }
  if (cmd.model.empty() && cmd.part.empty())
    throw InputError("weldtwin localize: give the part: its spec (--part SPEC) or its mesh (--model MESH)");
  if (cmd.units != "m" && cmd.units != "mm") throw input_error(cmd.model, "--units must be m or mm");
  if (cmd.model.empty() && cmd.units != "m")
    throw input_error(cmd.part, "--units applies to --model; a part spec's mesh is in metres");
  const std::optional<PartSpec> part =
      cmd.part.empty() ? std::nullopt : std::optional(PartSpec::load(cmd.part));
  const Mesh mesh =
      cmd.model.empty() ? load_mesh(part->mesh_path) : load_mesh(cmd.model, cmd.units == "mm" ? 1e-3 : 1.0);
  // The part made ready on its own thread while the cloud is read and the table found.
  const std::string keep_dir =
      cmd.no_part_cache ? "" : (cmd.part_cache.empty() ? default_part_cache_dir() : cmd.part_cache);
  const std::optional<PreparedPart> prepared =
      cmd.method == "paper"
          ? std::nullopt
          : std::optional<PreparedPart>(std::in_place, mesh, LocalizeSetting(), true, keep_dir);
  size_t dropped = 0;
  std::vector<Vec3> viewpoints;  // where the sensor saw each point from, if the cloud says
  std::vector<Vec3> cloud = read_cloud(cmd.scan, &dropped, &viewpoints);
  if (cloud.empty()) throw input_error(cmd.scan, "the cloud has no finite points");
  if (!cmd.roi.empty()) {
    if (cmd.roi.size() != 6) throw input_error(cmd.scan, "--roi takes xmin,ymin,zmin,xmax,ymax,zmax");
    std::vector<Vec3> kept, kept_viewpoints;
    for (size_t i = 0; i < cloud.size(); ++i) {
      const Vec3& p = cloud[i];
      if (p.x() >= cmd.roi[0] && p.y() >= cmd.roi[1] && p.z() >= cmd.roi[2] && p.x() <= cmd.roi[3] &&
          p.y() <= cmd.roi[4] && p.z() <= cmd.roi[5]) {
        kept.push_back(p);
        if (!viewpoints.empty()) kept_viewpoints.push_back(viewpoints[i]);
      }
    }
    cloud.swap(kept);
    viewpoints.swap(kept_viewpoints);
  }
  // Seam points from the part spec, when given: poses that weld the same place are not ambiguous, and its
  // weld tolerance is the bound a pose must meet.
  const std::vector<Vec3> seam_points = part ? part->seam_points(0.001) : std::vector<Vec3>();
  LocalizeSetting finding;
  finding.table.cell_top_z_m = 1e-3 * cmd.table_top_z_mm;
  const PoseEstimate pose =
      cmd.method == "paper"
          ? localize_paper(cloud, mesh)
          : localize(cloud, *prepared, part ? localize_setting_for(*part, finding) : finding, seam_points,
                     viewpoints);

  nlohmann::json out = pose_to_json(pose);
  out["method"] = cmd.method;
  out["scan_points"] = cloud.size();
  out["dropped_non_finite"] = dropped;
  out["seconds"] = pose.seconds;
  if (cmd.method != "paper") out["part_cache"] = pose.part_file;
  write_json_file(cmd.out, out);
  if (prepared) {
    const std::string why = prepared->keep_lookups();
    if (!why.empty() && !cmd.quiet)
      std::fprintf(stderr, "localize: the part's lookups not kept: %s\n", why.c_str());
  }
  if (!cmd.quiet)
    std::fprintf(stderr,
                 "localize: %s in %.2f s: fitness %.2f, rmse %.2f mm, coverage %.2f, ambiguity %.2f -> %s "
                 "(prepared part: %s)\n",
                 pose.found ? "found" : "not found",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
                 pose.fitness, 1e3 * pose.rmse_m, pose.coverage, pose.ambiguity, cmd.out.c_str(),
                 cmd.method == "paper" ? "none" : pose.part_file.c_str());
  if (!pose.found) {
    std::fprintf(stderr, "weldtwin: %s: part not found: %s\n", cmd.scan.c_str(), pose.reason.c_str());
    return kExitUntrustworthy;
  }
  return kExitPassed;
}

}  // namespace weldtwin
