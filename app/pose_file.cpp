#include "app/pose_file.hpp"

#include <cmath>

#include "app/json_file.hpp"
#include "core/error.hpp"
#include "perception/localizer.hpp"

namespace weldtwin {

nlohmann::json pose_to_json(const PoseEstimate& pose) {
  nlohmann::json out;
  out["T_base_part"] = transform_json(pose.T_base_part);
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
  // The direction it is widest in (part frame) and how many of the scan's 1 cm cells hold the pose that way.
  out["seam_error_bound_along"] = {pose.bound_direction_part.x(), pose.bound_direction_part.y()};
  out["seam_error_bound_cells"] = pose.bound_cells;
  out["yaw_bound_deg"] =
      std::isfinite(pose.yaw_bound_rad) ? nlohmann::json(rad2deg(pose.yaw_bound_rad)) : nlohmann::json();
  out["covariance_yaw_x_y"] = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    out["covariance_yaw_x_y"].push_back(
        {pose.covariance(r, 0), pose.covariance(r, 1), pose.covariance(r, 2)});
  if (pose.rays_cast) {
    out["see_through_share"] = pose.see_through_share;
    // The region of the model most rays went through, away from its depth edges (see_through.hpp).
    out["see_through_region"] = {
        {"rays_through", pose.region_through},
        {"rays_met", pose.region_rays},
        {"at_mm",
         {1e3 * pose.region_at_part.x(), 1e3 * pose.region_at_part.y(), 1e3 * pose.region_at_part.z()}}};
  }
  if (pose.rays_cast && pose.reached_coverage >= 0) out["reached_coverage"] = pose.reached_coverage;
  if (pose.rays_cast)  // the scan's points on the walls in patches off the model's (wall_patches.hpp)
    out["wall_patches_off"] = {{"share", pose.wall_patch_share},
                               {"largest_at_mm",
                                {1e3 * pose.wall_patch_at_part.x(), 1e3 * pose.wall_patch_at_part.y(),
                                 1e3 * pose.wall_patch_at_part.z()}},
                               {"largest_offset_mm", 1e3 * pose.wall_patch_offset_m}};
  if (pose.rays_cast)  // what the bound allows for mixed pixels at the model's depth edges
    out["depth_edge_bias_mm"] =
        std::isfinite(pose.edge_shift_m) ? nlohmann::json(1e3 * pose.edge_shift_m) : nlohmann::json();
  if (pose.rays_cast) {  // the sweep's passes, each fitted alone (pass_agreement.hpp)
    out["passes_fitted"] = pose.passes_fitted;
    out["pass_apart_mm"] = 1e3 * pose.pass_apart_m;
    out["pass_excess_mm"] = 1e3 * pose.pass_excess_m;
  }
  if (pose.table_known)  // the table the scan shows against the cell's (table_plane.hpp)
    out["table_against_cell"] = {{"height_mm", 1e3 * pose.table.height_m},
                                 {"tilt_deg", rad2deg(pose.table.tilt_rad)},
                                 {"seam_shift_mm", 1e3 * pose.table.shift_m},
                                 {"mount_off", pose.table_off}};
  out["beyond_share"] = pose.beyond_share;
  out["beyond_extent_mm"] = 1e3 * pose.beyond_extent_m;
  out["beyond_edge"] = {{"share", pose.beyond_line_share},
                        {"edge_length_mm", 1e3 * pose.beyond_line_length_m},
                        {"at_mm",
                         {1e3 * pose.beyond_line_at_part.x(), 1e3 * pose.beyond_line_at_part.y(),
                          1e3 * pose.beyond_line_at_part.z()}}};
  if (!pose.rays_cast) {
    out["margin_llr"] = std::isfinite(pose.margin_llr) ? nlohmann::json(pose.margin_llr) : nlohmann::json();
    out["rival_offset_mm"] = 1e3 * pose.rival_offset_m;
    if (std::isfinite(pose.margin_llr)) out["residual_margin_llr"] = pose.residual_margin_llr;
    out["wall_offset_mm"] = 1e3 * pose.wall_offset_m;
    out["level_offset_mm"] = 1e3 * pose.level_offset_m;
    out["wall_sigma_mm"] = 1e3 * pose.wall_sigma_m;
    out["wall_side_bias_mm"] = 1e3 * pose.wall_side_bias_m;
  } else if (pose.ambiguity > 0.0) {
    out["rival"] = {{"seams_mm", 1e3 * pose.rival_offset_m}, {"turn_deg", rad2deg(pose.rival_turn_rad)}};
  }
  return out;
}

nlohmann::json true_pose_json(const Iso3& T_base_part) {
  return {{"T_base_part", transform_json(T_base_part)}};
}

// A pose JSON: {"T_base_part": [[4x4 row-major]], ...} (docs/design.md).
Iso3 read_pose(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "pose");
  if (j.is_object() && j.contains("found") && j["found"] == false) {
    const std::string why =
        j.contains("reason") && j["reason"].is_string() ? j["reason"].get<std::string>() : "";
    throw input_error(path, "the pose says the part was not found" + (why.empty() ? "" : " (" + why + ")") +
                                ": localize it again before planning");
  }
  return read_transform_json(j, "T_base_part", path);
}

}  // namespace weldtwin
