// The localizer's recipe: the stages of perception/localize/ in order (see localizer.hpp).
#include "perception/localizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <limits>
#include <stdexcept>

#include "core/parallel_for.hpp"
#include "core/part_spec.hpp"
#include "perception/localize/part_model_file.hpp"
#include "perception/localize/stats.hpp"
#include "perception/localize/wall_side.hpp"

namespace weldtwin {
namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kMinModelSamples = 50;  // a mesh sampled to fewer points is too small to seek

}  // namespace

LocalizeSetting localize_setting_for(const PartSpec& part, LocalizeSetting base) {
  base.verdict.weld_tolerance_m = part.weld_tolerance_m;
  return base;
}

struct PreparedPart::Impl {
  PartModel model;
  double min_z = 0.0;  ///< the mesh's lowest vertex: the resting frame is the mesh frame lifted by it
  double model_spacing_m = 0.0;            ///< the setting it was prepared with
  std::shared_future<void> ready;          ///< the model built (or its error)
  std::string part_file = "off";           ///< PoseEstimate::part_file
  uint64_t key = 0;                        ///< of the kept files (0: none kept)
  std::string path;                        ///< the model's kept file
  size_t bricks_read = 0, cells_read = 0;  ///< the lookup grids' bricks and cells read from the kept lookups

  // A part given up while its build still runs (the command refused the cloud meanwhile) waits for the build
  // before its fields go: the build writes them. (Without the wait, the members declared after `ready` went
  // first, and the build saved the model under a freed path: a file named by heap bytes in the working
  // directory.)
  ~Impl() {
    if (ready.valid()) ready.wait();
  }

  void build(const Mesh& mesh, const LocalizeSetting& setting, const std::string& keep_dir) {
    min_z = 1e9;
    for (const Vec3& v : mesh.vertices) min_z = std::min(min_z, v.z());
    key = keep_dir.empty() ? 0 : part_model_key(mesh, min_z, setting.model);
    if (key == 0) {
      build_part_model(mesh, min_z, setting.model, setting.threads, model);
      part_file = keep_dir.empty() ? "off" : "not written: the program has no build id to tell builds apart";
      return;
    }
    path = part_model_path(keep_dir, key);
    Mesh rest;
    if (load_part_model(path, key, model, rest) == PartFileRead::kRead) {
      make_lookups(rest, setting.model, model);
      if (load_part_lookups(part_lookups_path(path), key, model, rest.faces.size()) == PartFileRead::kRead) {
        bricks_read = model.cache.bricks_made();
        cells_read = model.surface->cells_made();
      }
      part_file = "read";
      return;
    }
    rest = resting_mesh(mesh, min_z);
    build_part_model_at_rest(rest, setting.model, setting.threads, model);
    const std::string why = save_part_model(model, rest, key, path);
    part_file = why.empty() ? "written" : "not written: " + why;
  }
};

PreparedPart::PreparedPart(const Mesh& mesh, const LocalizeSetting& setting, bool in_background,
                           const std::string& keep_dir)
    : impl_(std::make_shared<Impl>()) {
  impl_->model_spacing_m = setting.model.spacing_m;
  if (in_background) {
    impl_->ready = std::async(std::launch::async, [impl = impl_.get(), mesh, setting, keep_dir] {
                     impl->build(mesh, setting, keep_dir);
                   }).share();
    return;
  }
  impl_->build(mesh, setting, keep_dir);
  std::promise<void> done;
  done.set_value();
  impl_->ready = done.get_future().share();
}

std::string PreparedPart::keep_lookups() const {
  impl_->ready.get();
  const Impl& p = *impl_;
  constexpr size_t kMinNew = 64, kNewShare = 20;  // written when a grid grew by 64 and a twentieth
  auto grown = [&](size_t made, size_t read) { return made >= read + std::max(kMinNew, read / kNewShare); };
  if (p.key == 0 || !(grown(p.model.cache.bricks_made(), p.bricks_read) ||
                      grown(p.model.surface->cells_made(), p.cells_read)))
    return "";
  return save_part_lookups(p.model, p.key, part_lookups_path(p.path));
}

PoseEstimate localize(const std::vector<Vec3>& scan_base, const Mesh& mesh, const LocalizeSetting& s,
                      const std::vector<Vec3>& seam_points, const std::vector<Vec3>& viewpoints_base) {
  const auto t0 = Clock::now();
  const PreparedPart part(mesh, s, true);  // built while the table is found
  PoseEstimate out = localize(scan_base, part, s, seam_points, viewpoints_base);
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

PoseEstimate localize(const std::vector<Vec3>& scan_base, const PreparedPart& part, const LocalizeSetting& s,
                      const std::vector<Vec3>& seam_points, const std::vector<Vec3>& viewpoints_base) {
  if (s.model.spacing_m != part.impl_->model_spacing_m)
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

  // 1. The table plane, the range noise, and the limits that follow from the noise (while the part may
  // still be in the making).
  const TablePlane table = find_table_plane(scan_base, s.table);
  stage("table");
  part.impl_->ready.get();
  out.part_file = part.impl_->part_file;
  const double min_z = part.impl_->min_z;
  PartModel& model = part.impl_->model;  // its nearest-sample grid fills as it is asked (the same answers)
  stage("model");
  if (model.pts.size() < kMinModelSamples) return finish("the model mesh is too small to sample");
  if (!table.found) {
    char why[240];
    std::snprintf(
        why, sizeof why,
        "no table plane in the scan: no plane within %.0f deg of level and %.1f m of the robot's base "
        "axis (a cloud in the robot's base frame, z up, in metres, with the table in view)",
        s.table.max_tilt_deg, s.table.reach_radius_m);
    return finish(why);
  }
  out.table_plane = table.plane;
  const double noise = table.noise_m;
  out.noise_m = noise;
  NoiseLimits limits;
  limits.noise_m = noise;
  limits.trim_m = s.icp.trim_sigmas * noise;
  limits.inlier_m = std::max(s.score.min_inlier_m, s.score.inlier_sigmas * noise);
  limits.edge_margin_m = s.icp.edge_margin_sigmas * noise;
  limits.height_cut_m = std::max(s.scene.min_height_m, s.scene.height_cut_sigmas * noise);

  // 2. The scene's points in the table frame.
  const ScenePoints scene = scene_points(scan_base, viewpoints_base, table.plane, limits, model.height,
                                         s.table.reach_radius_m, s.scene);
  out.object_points = static_cast<int>(scene.objects.size());
  if (!scene.ok) return finish(scene.reason);
  const Grid2 footprint =
      eroded(model.footprint, static_cast<int>(std::ceil(std::max(s.score.min_footprint_erosion_m,
                                                                  s.score.footprint_erosion_sigmas * noise) /
                                                         model.footprint.cell)));
  stage("objects");

  // 3. The global search.
  std::optional<Iso3> guess;
  if (s.use_initial_guess)
    guess = scene.T_table_base * s.initial_guess * make_transform(Vec3(0, 0, min_z), Mat3::Identity());
  const PoseSearchResult search = search_poses(scene, model, s.search, guess, s.threads);
  if (search.hypotheses.empty()) return finish(search.reason);
  const std::vector<Hypothesis>& hyps = search.hypotheses;
  stage("search");

  // 4. Refinement of the peaks, in batches until a finalist is allowed by the scan.
  const RefineInput refine_in{scene, scan_base, viewpoints_base, model, footprint};
  Refinement refinement =
      refine_hypotheses(refine_in, hyps, s.icp, s.score, s.see_through, s.refine, s.threads);
  std::vector<Candidate>& coarse = refinement.coarse;
  std::vector<Candidate>& refined = refinement.refined;
  stage("refine");
  if (refined.empty()) return finish("no pose survived the refinement");
  // With rays, of finalists scoring nearly alike the one that rays went through decisively less often (one
  // pass may see a part's long end from no side: the part turned end for end scores as well).
  if (!scene.ray_points.empty()) std::swap(refined.front(), refined[best_by_rays(refined, s.verdict)]);
  Candidate& best = refined.front();

  // 4b. The seams, to say which poses weld the same place and how far a pose may be off there: the part
  // spec's, or else the whole visible surface of the part (resting frame). How far the weld may be off is
  // taken where it is measured: for full circles about one axis, at the axis (a turn about it moves the weld
  // along the seam). The wall side's rivals are still told apart over the seam points: a fit turned about the
  // axis counts there, so that the margin never rests on a wall side the turn alone decides.
  const Iso3 lift = make_transform(Vec3(0, 0, -min_z), Mat3::Identity());  // mesh frame -> resting frame
  std::vector<Vec3> seams, seam_error_at;
  for (const Vec3& p : seam_points) seams.push_back(lift * p);
  for (const Vec3& p : seam_error_points(seam_points, s.verdict)) seam_error_at.push_back(lift * p);
  if (seams.empty())
    for (size_t i = 0; i < model.pts.size(); i += static_cast<size_t>(s.verdict.surface_stride))
      if (model.visible[i]) seams.push_back(model.pts[i]);
  if (seam_error_at.empty()) seam_error_at = seams;
  std::vector<const Candidate*> candidates;
  for (const Candidate& r : refined) candidates.push_back(&r);
  // With rays, a coarse rival that scores nearly as well is refined by them as the finalists were (its coarse
  // fit may stand a wall's thickness off, where the rays' fit would meet the best), and must leave the rays
  // room as the best does.
  std::vector<size_t> close;
  for (size_t i = 0; i < coarse.size(); ++i)
    if (!scene.ray_points.empty() &&
        coarse[i].score.support() >= s.verdict.ambiguity_ratio * best.score.support())
      close.push_back(i);
  parallel_for(close.size(), s.threads, [&](size_t k) {
    coarse[close[k]] = refine_with_rays(refine_in, coarse[close[k]], s.icp, s.score, s.see_through);
  });
  for (const Candidate& r : coarse) candidates.push_back(&r);
  const std::vector<const Candidate*> rivals = distinct_rivals(best, candidates, model, s.verdict);

  // 4c. Without viewpoints: the exact surface decides the wall side, and between the best pose and the
  // rivals the support cannot rule out.
  PoseUncertainty uncertainty;
  out.margin_llr = std::numeric_limits<double>::infinity();
  if (scene.ray_points.empty()) {
    std::vector<Iso3> starts{best.P};  // and, from where its fit settles, across the thin walls
    for (const Candidate* r : rivals)
      if (r->score.support() >= s.verdict.rival_support_share * best.score.support()) starts.push_back(r->P);
    const WallSideResult side = decide_wall_side(scene.icp_points, model, starts, seams, noise, s.surface,
                                                 s.uncertainty, s.wall_side, s.threads);
    best.P = side.best.P;
    best.score = score_pose(scene, footprint, model, best.P, s.score);
    uncertainty = side.uncertainty;
    out.margin_llr = side.margin_llr;
    out.rival_offset_m = side.rival_offset_m;
    out.residual_margin_llr = side.residual_margin_llr;
    out.wall_offset_m = side.best.wall_offset_m;
    out.level_offset_m = side.best.level_offset_m;
    out.wall_sigma_m = side.best.wall_sigma_m;
    out.wall_side_bias_m = wall_side_bias_m(model.thin_wall_m, out.wall_sigma_m);
  } else {
    uncertainty = pose_uncertainty(best.icp.terms, s.uncertainty);
    if (const Candidate* rival = strongest_rival(best, rivals, model, s.verdict)) {
      out.ambiguity = support_ratio(*rival, best);
      const RivalOffset apart = rival_offset(best, *rival, seam_error_at);
      out.rival_offset_m = apart.seams_m;
      out.rival_turn_rad = apart.turn_rad;
    }
    // Rays near the model's depth edges: the beam straddles two surfaces there and may report a range
    // between them (mixed pixels: seen from one side they do not average out, and the fit's residuals cannot
    // show it). The uncertainty counts a bias on them besides the noise, the same along the edge (the fine
    // fit once more, with them marked); where the pose rests on them, it grows.
    PlanarIcpSetting marked = s.icp;
    marked.rays.mark_depth_edges = true;
    const std::vector<ScanPoint> rays =
        rays_near_pose(scene, scan_base, viewpoints_base, model, best.P, s.icp.rays);
    const IcpResult f = planar_icp(thinned(rays, static_cast<size_t>(s.icp.fine_points)), scene, model,
                                   best.P, s.icp.fine_iterations, true, marked);
    const PoseUncertainty with_edges = pose_uncertainty(f.terms, s.uncertainty);
    out.edge_shift_m = std::max(0.0, seam_error_bound_m(with_edges, seam_error_at, s.uncertainty) -
                                         seam_error_bound_m(uncertainty, seam_error_at, s.uncertainty));
    out.edge_turn_rad =
        std::max(0.0, yaw_bound_rad(with_edges, s.uncertainty) - yaw_bound_rad(uncertainty, s.uncertainty));
    // Whether the sweep's passes, each fitted alone, agree on where the seams are (a mount that is off
    // moves each pass its own way).
    const PassAgreement passes =
        pass_agreement(rays, scene, model, best.P, seam_error_at, s.icp, s.uncertainty, s.passes);
    out.passes_fitted = passes.passes;
    // The walls patch by patch, on the rays' own residuals: each point on the face its ray meets, so no
    // point thrown past a thin wall's middle is taken for the far face (the voxels' centroids, matched with
    // the nearest face, left the near faces' patches 1-1.5 mm outside the model on right poses at the twin's
    // noise).
    const WallPatchFigure walls = walls_off_model(best.icp.terms, best.icp.beyond_trim, s.wall_patches);
    out.wall_patch_share = walls.off_share;
    out.wall_patch_at_part = lift.inverse() * walls.worst_at;
    out.wall_patch_offset_m = walls.worst_offset_m;
    out.pass_excess_m = passes.excess_m;
    out.pass_apart_m = passes.apart_m;
  }
  stage("fit");
  out.covariance = uncertainty.covariance;
  out.yaw_bound_rad = yaw_bound_rad(uncertainty, s.uncertainty);
  const SeamBound bound = seam_error_bound(uncertainty, seam_error_at, s.uncertainty);
  out.bound_cells = bound.cells;
  out.bound_direction_part = Vec3(bound.direction.x(), bound.direction.y(), 0.0);
  out.seam_error_bound_m = bound.bound_m + out.wall_side_bias_m + out.edge_shift_m;
  // A fit about as likely that welds within the tolerance of this one is part of the uncertainty; one beyond
  // it makes the answer ambiguous (the verdict).
  if (out.margin_llr < s.verdict.min_margin_llr && out.rival_offset_m <= s.verdict.weld_tolerance_m)
    out.seam_error_bound_m = std::max(out.seam_error_bound_m, out.rival_offset_m);

  out.T_base_part = orthonormalized(scene.T_base_table * best.P.inverse() * lift);
  out.fitness = best.score.region ? static_cast<double>(best.score.inliers) / best.score.region : 0.0;
  out.rmse_m = best.score.rmse;
  out.coverage = best.score.coverage;
  out.free_space = best.score.free_space;
  out.wall_residual = best.score.wall_residual;
  out.converged = best.icp.converged;
  out.iterations = best.icp.iterations;
  out.inliers = best.score.inliers;
  out.rays_cast = !scene.ray_points.empty();
  const PartExtent extent = scan_beyond_model(scene, model, best.P, s.extent);
  out.beyond_share = extent.share();
  out.beyond_extent_m = extent.extent_m;
  out.see_through_share = best.score.see_through;
  out.region_through = best.score.region_through;
  out.region_rays = best.score.region_rays;
  out.region_at_part = lift.inverse() * best.score.region_at;
  out.reached_coverage = best.score.reached_coverage;
  out.beyond_at_part = lift.inverse() * extent.centre;
  out.beyond_line_share = extent.line_share;
  out.beyond_line_length_m = extent.line_length_m;
  out.beyond_line_at_part = lift.inverse() * extent.line_centre;
  stage("verdict");
  VerdictInput verdict;
  verdict.score = best.score;
  verdict.rays = out.rays_cast;
  verdict.ambiguity = out.ambiguity;
  verdict.margin_llr = out.margin_llr;
  verdict.residual_margin_llr = out.residual_margin_llr;
  verdict.rival_offset_m = out.rival_offset_m;
  verdict.rival_turn_rad = out.rival_turn_rad;
  verdict.seam_error_bound_m = out.seam_error_bound_m;
  verdict.bound_direction_part = out.bound_direction_part;
  verdict.bound_cells = out.bound_cells;
  verdict.wall_offset_m = out.wall_offset_m;
  verdict.level_offset_m = out.level_offset_m;
  verdict.wall_side_bias_m = out.wall_side_bias_m;
  verdict.wall_sigma_m = out.wall_sigma_m;
  verdict.thin_wall_m = model.thin_wall_m;
  verdict.noise_m = noise;
  verdict.seams_given = !seam_points.empty();
  verdict.yaw_bound_rad = out.yaw_bound_rad;
  verdict.yaw_matters = !seams_turn_onto_themselves(seam_points, s.verdict);
  verdict.max_free_space = s.score.max_free_space;
  verdict.beyond_extent_m = out.beyond_extent_m;
  verdict.see_through_share = out.see_through_share;
  verdict.max_see_through_share = s.score.max_see_through_share;
  verdict.region_at_part = out.region_at_part;
  verdict.wall_patch_share = out.wall_patch_share;
  verdict.wall_patch_at_part = out.wall_patch_at_part;
  verdict.wall_patch_offset_m = out.wall_patch_offset_m;
  verdict.reached_coverage = out.reached_coverage;
  verdict.pass_excess_m = out.pass_excess_m;
  verdict.pass_apart_m = out.pass_apart_m;
  verdict.beyond_at_part = out.beyond_at_part;
  verdict.beyond_line_share = out.beyond_line_share;
  verdict.beyond_line_length_m = out.beyond_line_length_m;
  verdict.beyond_line_at_part = out.beyond_line_at_part;
  if (std::isfinite(s.table.cell_top_z_m)) {
    std::vector<Vec3> seams_base;
    for (const Vec3& p : seams.empty() ? seam_error_at : seams)
      seams_base.push_back(scene.T_base_table * best.P.inverse() * p);
    verdict.table_known = out.table_known = true;
    verdict.table = out.table = table_discrepancy(table.plane, s.table.cell_top_z_m, seams_base);
    out.table_off = table_is_off(verdict, s.verdict);
  }
  const std::string reason = verdict_reason(verdict, s.verdict);
  out.found = reason.empty();
  return finish(reason);
}

}  // namespace weldtwin
