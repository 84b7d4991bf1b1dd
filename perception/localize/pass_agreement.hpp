// Whether the sweep's passes agree on where the part is (clouds with viewpoints, in the order they were
// recorded). A LiDAR mount that is off (uncalibrated, or knocked) moves every point by an error that turns
// with the sensor: one pass sees the part shifted one way, a pass in another attitude another way, and the
// whole cloud's fit settles between them, as sure of itself as if the cloud were right (in the twin, 91 of
// 300 eight-pass cells with the mount off by 5 mm and 0.5 deg were accepted 3-15 mm off). Fitted alone, each
// pass puts the seams elsewhere; beyond what their noise explains, and by more than the weld tolerance, the
// cloud is not one rigid picture of the part.
//
// The passes are read from the order of the points: a pass records its points one revolution after another
// from a sensor moving a few millimetres between them, so the rays near the part split where the sensor
// jumped between two of them. A cloud in no such order splits into pieces too small to fit, and is not
// judged.
#pragma once

#include <vector>

#include "perception/localize/part_model.hpp"
#include "perception/localize/planar_icp.hpp"
#include "perception/localize/pose_uncertainty.hpp"
#include "perception/localize/scene_points.hpp"

namespace weldtwin {

struct PassAgreementSetting {
  /// Consecutive rays whose sensor positions are farther apart than this belong to different passes (the
  /// twin's passes move the sensor 2-7 mm per revolution) [m]
  double pass_jump_m = 0.03;
  int min_rays = 400;   ///< a pass with fewer rays near the part is not fitted alone
  int max_rays = 3000;  ///< at most this many of a pass's rays are used (evenly thinned)
  int iterations = 10;  ///< of each pass's own fit, from the whole cloud's pose
  /// A pass whose own fit leaves the part's turn uncertain by more than this (one standard deviation) ...
  double max_pass_turn_sd_deg = 2.0;  ///< [deg]
  /// ... or turns it farther than this from the pose is not compared (a mount off by 1 deg turns a pass by
  /// about as much) [deg]
  double max_pass_turn_deg = 5.0;
};

struct PassAgreement {
  int passes = 0;  ///< passes fitted alone (with enough rays and a determined pose)
  /// Over every two of them and every seam point: how far apart the two put it, less what their
  /// uncertainties allow in that direction (95 %; 0 when none is beyond) [m] ...
  double excess_m = 0.0;
  double apart_m = 0.0;  ///< ... and, for that pair, how far apart [m]
};

/// Fits each pass of `rays` (rays_near_pose's, in the cloud's order) alone from pose P (table frame -> part
/// frame) and compares where the passes put `seams` (part frame).
PassAgreement pass_agreement(const std::vector<ScanPoint>& rays, const ScenePoints& scene, PartModel& model,
                             const Iso3& P, const std::vector<Vec3>& seams, const PlanarIcpSetting& icp,
                             const PoseUncertaintySetting& uncertainty,
                             const PassAgreementSetting& setting = {});

}  // namespace weldtwin
