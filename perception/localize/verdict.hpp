// Stage 6 of the localizer: whether to trust the best pose. Ambiguity against the best distinct pose that
// is not the same weld (poses the part's symmetry, or its seams, map onto each other are the same weld), and
// the figures against their limits: free space, coverage, fitness, the walls' patches off the model.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/planar_icp.hpp"
#include "perception/localize/pose_score.hpp"
#include "perception/localize/table_plane.hpp"

namespace weldtwin {

struct VerdictSetting {
  double min_coverage = 0.45;  ///< share of the model's visible samples with scan points nearby
  double min_fitness = 0.55;   ///< share of the scan points in the model's region that it explains
  /// With rays: at most this share of the rays meeting the model's walls may lie in patches off them
  /// (wall_patches.hpp; right poses at most 7 % over 900 twin cells of eight passes, one pass and one pass
  /// at the real scan's noise) [share]
  double max_wall_patch_share = 0.15;
  double ambiguity_ratio = 0.85;  ///< a distinct pose scoring this close to the best is ambiguous ...
  /// ... unless, with rays, decisively more of them went through it than through the best: by this many
  /// standard deviations of the two counts (Poisson) ...
  double rays_decisive_sigmas = 5.0;
  int min_rays_decisive = 20;       ///< ... and by at least this many rays
  double same_pose_m = 0.008;       ///< poses closer than this ... [m]
  double same_pose_deg = 5.0;       ///< ... and this are one minimum, not rivals [deg]
  int symmetry_stride = 7;          ///< every this many model samples test a symmetry
  double symmetry_m = 0.0015;       ///< the model maps onto itself within this mean distance [m]
  double same_seam_m = 0.0015;      ///< every seam point maps within this of a seam point [m]
  double weld_tolerance_m = 0.001;  ///< a pose is accepted when its seam error bound is within this [m]
  double yaw_tolerance_deg = 0.5;   ///< ... and its yaw bound within this (the torch's angles) [deg]
  /// A bound's refusal names the direction it is widest in when fewer of the scan's cells than this hold
  /// the pose that way (then the walls facing that way were barely seen: the quantile is Student's, wide)
  double few_cells = 10.0;
  double min_margin_llr = 15.0;  ///< a fit that welds elsewhere must be this much less likely (nats)
  /// Without viewpoints, thin walls must be at least this many range noise sigmas thick: thinner, a point's
  /// side of a wall is a guess and the fit's bound does not hold
  double min_wall_to_noise = 2.0;
  double rival_support_share = 0.5;  ///< rivals of at least this share of the best's support are refitted
  int surface_stride = 7;            ///< without seams, every this many visible samples stand for them
  /// The scan may go on past the model's edges along at most this much (a clamp's pad and arm over the
  /// part's edge make 20-45 mm; a part larger than its model, a whole edge) [m]
  double max_beyond_extent_m = 0.07;
  /// ... and up past one straight top edge into open air along at most this share of the wall continued
  /// past it (a clamp's arm crosses a stretch of an edge; a part taller than its model, the whole edge
  /// seen) [share]
  double max_beyond_line_share = 0.6;
  /// With rays, coverage is judged against what the sweep's rays reached of the model (one short pass reaches
  /// a part of it): at least this share of the reached samples seen ...
  double min_reached_coverage = 0.7;
  /// ... and at least this share of the whole visible model [share]: a token floor (a match resting on a
  /// clamp's corner). One pass at the real scan's noise finds right poses whose sweep reached 8-20 % of the
  /// model and saw 90-100 % of that; of the 720 absent- and wrong-part cases there, the 30 refused first by a
  /// floor of 20 % are all refused by the tests after it (fitness, the scan past the model's edges or up past
  /// a top edge, the walls' patches, the rays through one region, the bound)
  double min_coverage_with_rays = 0.05;
  /// Where the cell's table is known, the table the scan shows may move the seams by at most this share of
  /// the weld tolerance by itself (TableDiscrepancy): beyond, the LiDAR's mount is off, and a mount off that
  /// much moves them along the table too, where the table cannot show it. In the twin, a calibrated mount
  /// (or the exact one) leaves the table within 0.15 mm and 0.025 deg; one off by 5 mm and 0.5 deg per axis
  /// moves the seams 0.5-108 mm so, median 4.3 mm (1,194 of 1,200 one-pass cells refused so) [share]
  double max_table_shift_share = 0.5;
};

/// A refined pose and its figures.
struct Candidate {
  Iso3 P = Iso3::Identity();  ///< table frame -> part frame
  IcpResult icp;
  Score score;
  bool rays_looked = false;  ///< score.see_through and score.reached_coverage are the rays' (else unknown)
};

/// The rivals that put the part elsewhere: not `best` itself, allowed by the scan (Score::allowed), not the
/// same pose found again (or a shallower minimum next to it), not mapped onto it by the part's symmetry. A
/// pose that only maps the seams onto themselves is a rival: the part's body stands elsewhere.
std::vector<const Candidate*> distinct_rivals(const Candidate& best,
                                              const std::vector<const Candidate*>& rivals, PartModel& model,
                                              const VerdictSetting& setting = {});

/// Whether, with rays, decisively more of them went through `more` than through `fewer` (a ray seen well
/// behind a surface is strong evidence against that surface): by rays_decisive_sigmas of the two counts and
/// by at least min_rays_decisive rays.
bool decisively_more_rays_through(const Candidate& more, const Candidate& fewer,
                                  const VerdictSetting& setting = {});

/// With rays: the finalist (index into `refined`, best first) that explains the scan best. The first, unless
/// another scores nearly as well (ambiguity_ratio) and decisively fewer rays went through it than through the
/// first: then the one of those with the fewest rays through it.
size_t best_by_rays(const std::vector<Candidate>& refined, const VerdictSetting& setting = {});

/// The distinct rival (distinct_rivals) with the most support, leaving out, with rays, those through which
/// decisively more rays went than through the best (null: none).
const Candidate* strongest_rival(const Candidate& best, const std::vector<const Candidate*>& rivals,
                                 PartModel& model, const VerdictSetting& setting = {});

/// A rival's support over the best's.
double support_ratio(const Candidate& rival, const Candidate& best);

/// The strongest rival's support over the best's (0: none).
double ambiguity(const Candidate& best, const std::vector<const Candidate*>& rivals, PartModel& model,
                 const VerdictSetting& setting = {});

/// How far a rival pose moves the part from the best: the farthest any of `seam_points` (part frame) moves
/// [m], and the turn between the two [rad].
struct RivalOffset {
  double seams_m = 0.0;
  double turn_rad = 0.0;
};
RivalOffset rival_offset(const Candidate& best, const Candidate& rival, const std::vector<Vec3>& seam_points);

/// Whether turning `seam_points` about the vertical through their centroid maps them onto themselves (a
/// full circle): then the part's yaw does not move the weld.
bool seams_turn_onto_themselves(const std::vector<Vec3>& seam_points, const VerdictSetting& setting = {});

/// The points whose moves are the seam error: the seam points themselves, or, for seams that turn onto
/// themselves, one point on their axis (a turn about it moves the weld along the seam, not off it; the
/// seam error is how far the axis moves).
std::vector<Vec3> seam_error_points(const std::vector<Vec3>& seam_points, const VerdictSetting& setting = {});

/// A level direction of the part's frame in words: "x", "y", or "(a, b) direction" (sign as x >= 0).
std::string part_direction_name(const Vec3& direction);

/// What the verdict weighs.
struct VerdictInput {
  Score score;                  ///< of the best pose
  bool rays = false;            ///< refined by rays cast from the points' viewpoints
  double ambiguity = 0.0;       ///< with rays: the best distinct rival's support over the best's
  double margin_llr = 0.0;      ///< without rays: log-likelihood ratio over the best fit welding elsewhere
  double rival_offset_m = 0.0;  ///< ... and how far it puts the seams (with rays: the strongest rival) [m]
  /// ... and the same ratio from the points' distances to the surface alone, without the view prior
  /// (negative: they prefer that fit) [nats]
  double residual_margin_llr = std::numeric_limits<double>::infinity();
  double rival_turn_rad = 0.0;      ///< with rays: the turn between the best and the strongest rival [rad]
  double seam_error_bound_m = 0.0;  ///< 95 % bound on the seam error from the fit [m]
  Vec3 bound_direction_part = Vec3::Zero();  ///< the direction it is widest in (part frame, level) ...
  double bound_cells = 0.0;                  ///< ... and how many of the scan's cells hold the pose that way
  double yaw_bound_rad = 0.0;                ///< 95 % bound on the turn about the table normal [rad]
  bool yaw_matters = true;        ///< false: the seams map onto themselves under turns (full circles)
  double wall_offset_m = 0.0;     ///< without rays: median distance of the scan's walls from the model's [m]
  double level_offset_m = 0.0;    ///< ... and median height of its level faces above the model's [m]
  double wall_side_bias_m = 0.0;  ///< the part of the bound that allows for points on the wrong face [m]
  double wall_sigma_m = 0.0;      ///< the spread of the scan's points across walls [m]
  double thin_wall_m = 0.0;       ///< the part's thin walls' thickness [m]
  double noise_m = 0.0;           ///< the range noise sigma, from the table [m]
  bool seams_given = true;        ///< false: the bound is taken over the part's whole visible surface
  double max_free_space = 0.02;
  double see_through_share = 0.0;  ///< with rays: the share of those crossing the model that went through it
  double max_see_through_share = 0.15;
  Vec3 region_at_part = Vec3::Zero();  ///< with rays: score.region_at in the part frame [m]
  /// With rays: the share of the rays meeting the model's walls in patches off them (wall_patches.hpp),
  /// the largest such patch's centre (part frame) and mean residual [m]
  double wall_patch_share = 0.0;
  Vec3 wall_patch_at_part = Vec3::Zero();
  double wall_patch_offset_m = 0.0;
  double reached_coverage = -1.0;  ///< with rays: the coverage of the samples they reached (-1: none)
  double beyond_extent_m = 0.0;    ///< the longest stretch of the model's faces continued past its edges with
                                   ///< the scan on them [m] ...
  Vec3 beyond_at_part = Vec3::Zero();  ///< ... and its centre (part frame) [m]
  /// The share of one wall continued up past one straight top edge into open air with the scan on it (the
  /// most of any edge), that edge's length and where (part frame) [m]
  double beyond_line_share = 0.0;
  double beyond_line_length_m = 0.0;
  Vec3 beyond_line_at_part = Vec3::Zero();
  /// With viewpoints: how much farther apart than their 95 % bound the two passes that disagree most put
  /// the seams, each fitted alone [m] (pass_agreement.hpp) ...
  double pass_excess_m = 0.0;
  double pass_apart_m = 0.0;  ///< ... and how far apart [m]
  bool table_known = false;   ///< the cell's table is known: `table` is the scan's against it
  TableDiscrepancy table;
};

/// Whether the table the scan shows lies so far from the cell's (when known) that it alone moves the seams
/// beyond max_table_shift_share of the weld tolerance: the LiDAR's mount is off.
bool table_is_off(const VerdictInput& in, const VerdictSetting& setting = {});

/// Why the figures refuse the pose, or "" when they accept it: in words a person can act on.
std::string verdict_reason(const VerdictInput& in, const VerdictSetting& setting = {});

}  // namespace weldtwin
