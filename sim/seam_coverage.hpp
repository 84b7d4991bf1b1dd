// How well a sweep saw each weld seam: the fraction of seam stations (every 2 mm) with exact part points on
// both members of the joint nearby. Used to check that a sweep program sees every seam at any part pose.
#pragma once

#include <string>
#include <vector>

#include "core/part_spec.hpp"

namespace weldtwin {

struct SeamCoverage {
  std::string seam;
  int stations = 0;     ///< stations along the seam
  int seen = 0;         ///< stations with points on both members within `radius_m`
  int seen_one = 0;     ///< stations with points on at least one member
  int points_near = 0;  ///< part points within `radius_m` of the seam
  double fraction() const { return stations ? static_cast<double>(seen) / stations : 0.0; }
  double fraction_one() const { return stations ? static_cast<double>(seen_one) / stations : 0.0; }
};

struct CoverageSetting {
  double station_step_m = 0.002;  ///< spacing of the stations along the seam
  double radius_m = 0.008;        ///< neighbourhood of a station
  double on_surface_m = 0.0015;   ///< how close to a member's surface a point must be
  double end_margin_m = 0.004;    ///< stations this close to a seam end are not counted
};

/// Coverage of every seam of `part` at pose T_base_part by part points (base frame, exact or noisy).
std::vector<SeamCoverage> seam_coverage(const PartSpec& part, const Iso3& T_base_part,
                                        const std::vector<Vec3>& part_points_base,
                                        const CoverageSetting& s = {});

}  // namespace weldtwin
