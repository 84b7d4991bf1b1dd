#include "app/localize_command.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "perception/localizer.hpp"
#include "perception/mesh_io.hpp"
#include "perception/paper_localizer.hpp"
#include "pipeline/outcome.hpp"
#include "pipeline/weld_pipeline.hpp"

namespace weldtwin {

nlohmann::json pose_to_json(const PoseEstimate& pose) {
  nlohmann::json out;
  out["T_base_part"] = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    out["T_base_part"].push_back({pose.T_base_part.matrix()(r, 0), pose.T_base_part.matrix()(r, 1),
                                  pose.T_base_part.matrix()(r, 2), pose.T_base_part.matrix()(r, 3)});
  out["found"] = pose.found;
  out["reason"] = pose.reason;
  out["fitness"] = pose.fitness;
  out["rmse_m"] = pose.rmse_m;
  out["coverage"] = pose.coverage;
  out["free_space"] = pose.free_space;
  out["wall_residual_sigmas"] = pose.wall_residual;
  out["noise_m"] = pose.noise_m;
  out["stage_seconds"] = nlohmann::json::object();
  for (const auto& [stage, sec] : pose.stage_seconds) out["stage_seconds"][stage] = sec;
  out["ambiguity"] = pose.ambiguity;
  out["converged"] = pose.converged;
  out["iterations"] = pose.iterations;
  out["inliers"] = pose.inliers;
  out["table_plane"] = {pose.table_plane[0], pose.table_plane[1], pose.table_plane[2], pose.table_plane[3]};
  out["object_points"] = pose.object_points;
  out["rays_cast"] = pose.rays_cast;
  // How far to trust it: a 95 % bound on any seam point's error from the fit, the covariance of the part's
  // (yaw [rad], x [m], y [m]) in its own frame, and (without viewpoints) the log-likelihood ratio over the
  // best fit that welds elsewhere.
  out["seam_error_bound_mm"] = std::isfinite(pose.seam_error_bound_m)
                                   ? nlohmann::json(1e3 * pose.seam_error_bound_m)
                                   : nlohmann::json();
  out["yaw_bound_deg"] =
      std::isfinite(pose.yaw_bound_rad) ? nlohmann::json(rad2deg(pose.yaw_bound_rad)) : nlohmann::json();
  out["covariance_yaw_x_y"] = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    out["covariance_yaw_x_y"].push_back(
        {pose.covariance(r, 0), pose.covariance(r, 1), pose.covariance(r, 2)});
  if (pose.rays_cast) out["see_through_share"] = pose.see_through_share;
  if (pose.rays_cast && pose.reached_coverage >= 0) out["reached_coverage"] = pose.reached_coverage;
  if (pose.rays_cast)  // what the bound allows for mixed pixels at the model's depth edges
    out["depth_edge_bias_mm"] =
        std::isfinite(pose.edge_shift_m) ? nlohmann::json(1e3 * pose.edge_shift_m) : nlohmann::json();
  out["beyond_share"] = pose.beyond_share;
  out["beyond_extent_mm"] = 1e3 * pose.beyond_extent_m;
  if (!pose.rays_cast) {
    out["margin_llr"] = std::isfinite(pose.margin_llr) ? nlohmann::json(pose.margin_llr) : nlohmann::json();
    out["rival_offset_mm"] = 1e3 * pose.rival_offset_m;
    if (std::isfinite(pose.margin_llr)) out["residual_margin_llr"] = pose.residual_margin_llr;
    out["wall_offset_mm"] = 1e3 * pose.wall_offset_m;
    out["level_offset_mm"] = 1e3 * pose.level_offset_m;
    out["wall_sigma_mm"] = 1e3 * pose.wall_sigma_m;
    out["wall_side_bias_mm"] = 1e3 * pose.wall_side_bias_m;
  }
  return out;
}

int run_localize(const LocalizeCommand& cmd) {
  const auto started =
      std::chrono::steady_clock::now();  // the files' reading and the part's making count too
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
  const std::optional<PreparedPart> prepared =
      cmd.method == "paper" ? std::nullopt
                            : std::optional<PreparedPart>(std::in_place, mesh, LocalizeSetting(), true);
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
  const PoseEstimate pose =
      cmd.method == "paper"
          ? localize_paper(cloud, mesh)
          : localize(cloud, *prepared, part ? localize_setting_for(*part) : LocalizeSetting(), seam_points,
                     viewpoints);

  nlohmann::json out = pose_to_json(pose);
  out["method"] = cmd.method;
  out["scan_points"] = cloud.size();
  out["dropped_non_finite"] = dropped;
  out["seconds"] = pose.seconds;
  std::ofstream(cmd.out) << out.dump(1) << '\n';
  if (!cmd.quiet)
    std::fprintf(stderr,
                 "localize: %s in %.2f s: fitness %.2f, rmse %.2f mm, coverage %.2f, ambiguity %.2f -> %s\n",
                 pose.found ? "found" : "not found",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
                 pose.fitness, 1e3 * pose.rmse_m, pose.coverage, pose.ambiguity, cmd.out.c_str());
  if (!pose.found) {
    std::fprintf(stderr, "weldtwin: %s: part not found: %s\n", cmd.scan.c_str(), pose.reason.c_str());
    return kExitUntrustworthy;
  }
  return kExitPassed;
}

}  // namespace weldtwin
