// Stage 6 of the localizer: whether to trust the best pose. Ambiguity against the best distinct pose that
// is not the same weld (poses the part's symmetry, or its seams, map onto each other are the same weld), and
// the figures against their limits: free space, coverage, fitness, the walls' residual.
#pragma once

#include <string>
#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/planar_icp.hpp"
#include "perception/localize/pose_score.hpp"

namespace weldtwin {

struct VerdictSetting {
  double min_coverage = 0.45;       ///< share of the model's visible samples with scan points nearby
  double min_fitness = 0.55;        ///< share of the scan points in the model's region that it explains
  double max_wall_residual = 0.58;  ///< median |residual| on the walls, in table noise sigmas (a different
                                    ///< shape fits the walls worse than the noise explains)
  double ambiguity_ratio = 0.85;    ///< a distinct pose scoring this close to the best is ambiguous
  double same_pose_m = 0.008;       ///< poses closer than this ... [m]
  double same_pose_deg = 5.0;       ///< ... and this are one minimum, not rivals [deg]
  int symmetry_stride = 7;          ///< every this many model samples test a symmetry
  double symmetry_m = 0.0015;       ///< the model maps onto itself within this mean distance [m]
  double same_seam_m = 0.0015;      ///< every seam point maps within this of a seam point [m]
};

/// A refined pose and its figures.
struct Candidate {
  Iso3 P = Iso3::Identity();  ///< table frame -> part frame
  IcpResult icp;
  Score score;
};

/// The best distinct rival's support over the best's (0: none). `lift` maps the mesh frame into the resting
/// frame; `seam_points` are in the mesh frame.
double ambiguity(const Candidate& best, const std::vector<const Candidate*>& rivals, PartModel& model,
                 const std::vector<Vec3>& seam_points, const Iso3& lift, double max_free_space,
                 const VerdictSetting& setting = {});

/// Why the figures refuse the pose, or "" when they accept it.
std::string verdict_reason(const Score& best, double ambiguity, double max_free_space,
                           const VerdictSetting& setting = {});

}  // namespace weldtwin
