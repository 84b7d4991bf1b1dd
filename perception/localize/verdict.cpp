#include "perception/localize/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace weldtwin {
namespace {

// Whether the model maps onto itself under D (part frame): a symmetry, so poses D apart are the same weld.
bool self_similar(PartModel& model, const Iso3& D, const VerdictSetting& s) {
  double sum = 0.0;
  int n = 0;
  double d2 = 0.0;
  for (size_t k = 0; k < model.pts.size(); k += static_cast<size_t>(s.symmetry_stride)) {
    if (!model.visible[k]) continue;
    if (model.tree.nearest(D * model.pts[k], d2) < 0) continue;
    sum += std::sqrt(d2);
    ++n;
  }
  return n > 0 && sum / n < s.symmetry_m;
}

// Whether D (part frame to part frame) maps every seam point within same_seam_m of some seam point (they are
// about 1 mm apart).
bool same_seams(const std::vector<Vec3>& seam, const Iso3& D, const VerdictSetting& s) {
  if (seam.empty()) return false;
  for (const Vec3& p : seam) {
    const Vec3 q = D * p;
    double best = 1e9;
    for (const Vec3& r : seam) best = std::min(best, (q - r).squaredNorm());
    if (best > s.same_seam_m * s.same_seam_m) return false;
  }
  return true;
}

Vec3 centroid(const std::vector<Vec3>& points) {
  Vec3 c = Vec3::Zero();
  for (const Vec3& p : points) c += p;
  return c / static_cast<double>(points.size());
}

}  // namespace

std::vector<const Candidate*> distinct_rivals(const Candidate& best,
                                              const std::vector<const Candidate*>& rivals, PartModel& model,
                                              const VerdictSetting& s) {
  std::vector<const Candidate*> out;
  for (const Candidate* r : rivals) {
    if (r == &best || !r->score.allowed()) continue;
    const Iso3 D = best.P * r->P.inverse();  // part frame to part frame
    // The same pose found twice, or a shallower minimum next to it: not a rival.
    if (D.translation().norm() < s.same_pose_m &&
        Eigen::AngleAxisd(D.linear()).angle() < deg2rad(s.same_pose_deg))
      continue;
    // A pose the part's symmetry maps onto this one is the same. One that only puts the seams in the same
    // places is not: the part's body (what the torch must clear) stands elsewhere.
    if (self_similar(model, D, s)) continue;
    out.push_back(r);
  }
  return out;
}

bool seams_turn_onto_themselves(const std::vector<Vec3>& seams, const VerdictSetting& s) {
  if (seams.empty()) return false;
  const Vec3 c = centroid(seams);
  constexpr double kTurnDeg = 5.0;  // a turn this big moves a seam that is not a circle off itself
  const Iso3 D = make_transform(c, Mat3::Identity()) * planar_pose(0, 0, 0, deg2rad(kTurnDeg)) *
                 make_transform(-c, Mat3::Identity());
  return same_seams(seams, D, s);
}

std::vector<Vec3> seam_error_points(const std::vector<Vec3>& seams, const VerdictSetting& s) {
  if (!seams_turn_onto_themselves(seams, s)) return seams;
  return {centroid(seams)};
}

bool decisively_more_rays_through(const Candidate& more, const Candidate& fewer, const VerdictSetting& s) {
  if (!more.rays_looked || !fewer.rays_looked) return false;
  const int excess = more.score.through_count - fewer.score.through_count;
  return excess >= s.min_rays_decisive &&
         excess > s.rays_decisive_sigmas *
                      std::sqrt(static_cast<double>(more.score.through_count + fewer.score.through_count));
}

size_t best_by_rays(const std::vector<Candidate>& refined, const VerdictSetting& s) {
  size_t k = 0;
  for (size_t i = 1; i < refined.size(); ++i) {
    const Candidate& r = refined[i];
    if (r.score.allowed() && r.score.support() >= s.ambiguity_ratio * refined[0].score.support() &&
        decisively_more_rays_through(refined[0], r, s) &&
        (k == 0 || r.score.through_count < refined[k].score.through_count))
      k = i;
  }
  return k;
}

const Candidate* strongest_rival(const Candidate& best, const std::vector<const Candidate*>& rivals,
                                 PartModel& model, const VerdictSetting& s) {
  const Candidate* out = nullptr;
  for (const Candidate* r : distinct_rivals(best, rivals, model, s)) {
    // With rays, a rival through which decisively more rays went than through the best explains the scan
    // worse, whatever its support.
    if (decisively_more_rays_through(*r, best, s)) continue;
    if (!out || r->score.support() > out->score.support()) out = r;
  }
  return out;
}

double support_ratio(const Candidate& rival, const Candidate& best) {
  return rival.score.support() / std::max(1e-9, best.score.support());
}

double ambiguity(const Candidate& best, const std::vector<const Candidate*>& rivals, PartModel& model,
                 const VerdictSetting& s) {
  const Candidate* r = strongest_rival(best, rivals, model, s);
  return r ? support_ratio(*r, best) : 0.0;
}

RivalOffset rival_offset(const Candidate& best, const Candidate& rival,
                         const std::vector<Vec3>& seam_points) {
  const Iso3 D = best.P * rival.P.inverse();  // part frame to part frame
  RivalOffset out;
  for (const Vec3& p : seam_points) out.seams_m = std::max(out.seams_m, (D * p - p).norm());
  out.turn_rad = Eigen::AngleAxisd(D.linear()).angle();
  return out;
}

std::string part_direction_name(const Vec3& d) {
  constexpr double kAlongAxis = 0.95;  // cos 18 deg: named by the axis it is nearest
  const Vec3 u = d.normalized();
  if (std::abs(u.x()) >= kAlongAxis) return "x";
  if (std::abs(u.y()) >= kAlongAxis) return "y";
  char buf[64];
  std::snprintf(buf, sizeof buf, "(%.2f, %.2f) direction", std::abs(u.x()), u.x() < 0 ? -u.y() : u.y());
  return buf;
}

bool table_is_off(const VerdictInput& in, const VerdictSetting& s) {
  return in.table_known && in.table.shift_m > s.max_table_shift_share * s.weld_tolerance_m;
}

std::string verdict_reason(const VerdictInput& in, const VerdictSetting& s) {
  const Score& best = in.score;
  const double fitness = best.region ? static_cast<double>(best.inliers) / best.region : 0.0;
  const double tol = s.weld_tolerance_m;
  const char* where =
      in.seams_given
          ? "at the seams"
          : "somewhere on the part (no seams given: with the part spec the bound is taken at its seams)";
  char buf[600];
  // The table first: a scan assembled through a mount that is off is off everywhere.
  if (table_is_off(in, s)) {
    std::snprintf(
        buf, sizeof buf,
        "the table is seen %.1f mm %s where the cell has it and tilted %.2f deg, which alone moves the seams "
        "%.1f mm (%.1f mm allowed): the LiDAR's mount is off: calibrate it (weldtwin calibrate), or, if "
        "the cell file's table top_z_m is not where the table is, correct it",
        1e3 * std::abs(in.table.height_m), in.table.height_m > 0 ? "above" : "below",
        rad2deg(in.table.tilt_rad), 1e3 * in.table.shift_m, 1e3 * s.max_table_shift_share * tol);
    return buf;
  }
  if (best.free_space > in.max_free_space) return "the table is seen where the best match would stand";
  if (in.rays && in.see_through_share > in.max_see_through_share) {
    std::snprintf(buf, sizeof buf,
                  "the LiDAR saw through the best match: %.0f %% of the rays crossing it reach points behind "
                  "its surface",
                  100 * in.see_through_share);
    return buf;
  }
  if (in.rays && in.reached_coverage >= 0.0) {
    // What the sweep's rays reached of the model is what it could have seen.
    if (in.reached_coverage < s.min_reached_coverage || best.coverage < s.min_coverage_with_rays) {
      std::snprintf(
          buf, sizeof buf,
          "the best match covers too little of the model: %.0f %% of what the LiDAR's rays reached of it "
          "(%.0f %% needed), %.0f %% of all of it (%.0f %% needed)",
          100 * in.reached_coverage, 100 * s.min_reached_coverage, 100 * best.coverage,
          100 * s.min_coverage_with_rays);
      return buf;
    }
  } else if (best.coverage < s.min_coverage) {
    return "the best match covers too little of the model";
  }
  if (fitness < s.min_fitness) return "the part fits the scan poorly";
  if (in.beyond_extent_m > s.max_beyond_extent_m) {
    const Vec3& c = in.beyond_at_part;
    std::snprintf(buf, sizeof buf,
                  "the scan goes on past the model's edges along %.0f mm around (%.0f, %.0f, %.0f) mm of the "
                  "part: a different part, or the part is larger than its CAD there: check the part and its "
                  "model",
                  1e3 * in.beyond_extent_m, 1e3 * c.x(), 1e3 * c.y(), 1e3 * c.z());
    return buf;
  }
  if (in.beyond_line_share > s.max_beyond_line_share) {
    const Vec3& c = in.beyond_line_at_part;
    std::snprintf(buf, sizeof buf,
                  "the scan goes on above one of the model's top edges (%.0f mm long) over %.0f %% of it, "
                  "around (%.0f, %.0f, %.0f) mm of the part: a different part, the part taller than its CAD "
                  "there, or a clamp over that edge: check the part, its model and the clamps",
                  1e3 * in.beyond_line_length_m, 100 * in.beyond_line_share, 1e3 * c.x(), 1e3 * c.y(),
                  1e3 * c.z());
    return buf;
  }
  // With rays, the walls' patches off the model tell a different shape; without them the scan's own
  // surfaces (neighbourhood centroids, where the noise averages out) against the model's.
  if (in.rays && in.wall_patch_share > s.max_wall_patch_share) {
    const Vec3& c = in.wall_patch_at_part;
    std::snprintf(
        buf, sizeof buf,
        "%.0f %% of the scan on the part's walls lies off the model's walls (judged in patches by "
        "their own noise; the largest around (%.0f, %.0f, %.0f) mm of the part, %.1f mm off): a "
        "different part, the part off its CAD there, or the LiDAR's mount off (it warps the walls): "
        "check the part and its model, or calibrate the mount (weldtwin calibrate)",
        100 * in.wall_patch_share, 1e3 * c.x(), 1e3 * c.y(), 1e3 * c.z(),
        1e3 * std::abs(in.wall_patch_offset_m));
    return buf;
  }
  if (!in.rays && in.wall_offset_m > tol) {
    std::snprintf(
        buf, sizeof buf,
        "the scan's walls lie %.1f mm from the model's (median; tolerance %.1f mm): a different part, "
        "or the part differs from its CAD: check the part and its model",
        1e3 * in.wall_offset_m, 1e3 * tol);
    return buf;
  }
  if (!in.rays && std::abs(in.level_offset_m) > tol) {
    std::snprintf(
        buf, sizeof buf,
        "the part's level faces lie %.1f mm %s the model's (median; tolerance %.1f mm): a different "
        "part, or the part differs from its CAD: check the part and its model",
        1e3 * std::abs(in.level_offset_m), in.level_offset_m > 0 ? "above" : "below", 1e3 * tol);
    return buf;
  }
  // Passes that disagree beyond their noise, by more than the tolerance: the cloud is not one rigid picture
  // of the part, and a fit of all of it settles between them.
  if (in.rays && in.pass_excess_m > tol) {
    std::snprintf(buf, sizeof buf,
                  "the sweep's passes disagree: fitted alone, two put the seams %.1f mm apart (%.1f mm more "
                  "than their noise explains; tolerance %.1f mm): the LiDAR's mount is off (calibrate it: "
                  "weldtwin calibrate), the part moved during the sweep, or it differs from its CAD",
                  1e3 * in.pass_apart_m, 1e3 * in.pass_excess_m, 1e3 * tol);
    return buf;
  }
  // After the passes: a mount that is off also leaves rays through parts of the model, and the passes say
  // what to do about it.
  if (in.rays && best.region_seen_through) {
    const Vec3& c = in.region_at_part;
    std::snprintf(
        buf, sizeof buf,
        "the LiDAR saw through the best match around (%.0f, %.0f, %.0f) mm of the part: %d of the %d "
        "rays that met it there reach points behind its surface: a different part, or not where "
        "the match puts it",
        1e3 * c.x(), 1e3 * c.y(), 1e3 * c.z(), best.region_through, best.region_rays);
    return buf;
  }
  if (in.ambiguity >= s.ambiguity_ratio) {
    // With rays: what the rival would change, and what to do about it.
    if (in.rival_offset_m <= tol)
      std::snprintf(
          buf, sizeof buf,
          "ambiguous: a pose turned %.0f deg from the best fits the scan about as well (%.0f %% of its "
          "support); it puts the seams where the best does (%.1f mm away) but the part's body "
          "elsewhere, and the scan does not tell which: sweep again so that the LiDAR sees the part "
          "from another side",
          rad2deg(in.rival_turn_rad), 100 * in.ambiguity, 1e3 * in.rival_offset_m);
    else
      std::snprintf(
          buf, sizeof buf,
          "ambiguous: a pose that puts the seams %.1f mm away (turned %.1f deg) fits the scan about as well "
          "(%.0f %% of the best's support): sweep again so that the LiDAR sees the part from "
          "another side",
          1e3 * in.rival_offset_m, rad2deg(in.rival_turn_rad), 100 * in.ambiguity);
    return buf;
  }
  if (!in.rays && in.margin_llr < s.min_margin_llr && in.rival_offset_m > tol) {
    std::snprintf(buf, sizeof buf,
                  "ambiguous: a pose that puts the seams %.1f mm away fits almost as well (likelihood ratio "
                  "e^%.1f; e^%.0f needed), as when the scan may lie on either side of a wall: sweep again so "
                  "that the LiDAR sees the part's walls from more sides",
                  1e3 * in.rival_offset_m, in.margin_llr, s.min_margin_llr);
    return buf;
  }
  // Without viewpoints, where the faces would be seen from (the view prior) chose the best fit over one
  // that welds elsewhere, against the points' distances to the surface: two lines of evidence, each
  // decisive, disagree. Measured at the real scan's noise, one pass and its rescans, 1,200 cells: every
  // pose accepted on the wrong side of a wall had the distances prefer the other side by e^27 or more
  // (with either prior), every right pose by e^6 at most.
  if (!in.rays && in.rival_offset_m > tol && in.residual_margin_llr < -s.min_margin_llr) {
    std::snprintf(buf, sizeof buf,
                  "contested: the points lie closer to the part's surface with the seams %.1f mm away "
                  "(likelihood ratio e^%.1f), and only which faces a scanner would see picks this pose: the "
                  "scan may lie on either side of a wall: sweep again so that the LiDAR sees the part's "
                  "walls from more sides, or give the cloud with its viewpoints",
                  1e3 * in.rival_offset_m, -in.residual_margin_llr);
    return buf;
  }
  // Without viewpoints, a range noise comparable to the walls' thickness throws so many points past the
  // walls' middles that the fit's own figures no longer bound its error (measured in the twin, one pass:
  // with 2.3 mm on the table against 3.2 mm walls, 42 % of the poses lay beyond their bound and 2 of 180
  // were accepted over 1 mm off; with 0.6-1.1 mm, none of 540).
  if (!in.rays && in.thin_wall_m > 0.0 && in.thin_wall_m < s.min_wall_to_noise * in.noise_m) {
    std::snprintf(
        buf, sizeof buf,
        "the range noise (%.1f mm, measured on the table) is more than %.0f %% of the part's wall "
        "thickness (%.1f mm) and the cloud carries no viewpoints, so a point's side of a wall cannot "
        "be told: give the cloud with its viewpoints (PCD fields vp_x vp_y vp_z)",
        1e3 * in.noise_m, 100.0 / s.min_wall_to_noise, 1e3 * in.thin_wall_m);
    return buf;
  }
  if (!(in.seam_error_bound_m <= tol) && in.wall_side_bias_m > 0.5 * in.seam_error_bound_m) {
    std::snprintf(
        buf, sizeof buf,
        "the pose is uncertain by up to %.2f mm %s (95 %%; tolerance %.2f mm): the points spread %.1f mm "
        "across walls %.1f mm thick and the cloud carries no viewpoints, so a point's side of a wall is a "
        "guess: give the cloud with its viewpoints (PCD fields vp_x vp_y vp_z), or sweep so that the LiDAR "
        "sees the walls more squarely",
        1e3 * in.seam_error_bound_m, where, 1e3 * tol, 1e3 * in.wall_sigma_m, 1e3 * in.thin_wall_m);
    return buf;
  }
  if (std::isinf(in.seam_error_bound_m))
    return "the scan holds nothing that fixes the part's place in some direction (its walls facing that way "
           "were not seen, or only at grazing incidence): sweep again so that the LiDAR sees more of the "
           "part's walls";
  if (!(in.seam_error_bound_m <= tol)) {
    // Where few cells hold the pose in the bound's direction, the walls facing that way were barely seen.
    std::string advice = "sweep again so that the LiDAR sees more of the part's walls";
    if (in.bound_cells > 0.0 && in.bound_cells < s.few_cells) {
      const std::string along = part_direction_name(in.bound_direction_part);
      char few[300];
      std::snprintf(
          few, sizeof few,
          "along the part's %s only about %.0f small patches of its walls hold it (those facing that "
          "way were barely seen): sweep again so that the LiDAR sees the part's walls facing along "
          "its %s",
          along.c_str(), in.bound_cells, along.c_str());
      advice = few;
    }
    std::snprintf(buf, sizeof buf, "the pose is uncertain by up to %.2f mm %s (95 %%; tolerance %.2f mm): %s",
                  1e3 * in.seam_error_bound_m, where, 1e3 * tol, advice.c_str());
    return buf;
  }
  if (in.yaw_matters && !(in.yaw_bound_rad <= deg2rad(s.yaw_tolerance_deg))) {
    std::snprintf(buf, sizeof buf,
                  "the part's turn is uncertain by up to %.2f deg (95 %%; tolerance %.2f deg for the torch's "
                  "angles): sweep again so that the LiDAR sees more of the part's walls",
                  rad2deg(in.yaw_bound_rad), s.yaw_tolerance_deg);
    return buf;
  }
  return "";
}

}  // namespace weldtwin
