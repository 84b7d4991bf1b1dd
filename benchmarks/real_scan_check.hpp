// The localization survey on real scans of a known placement (a directory such as the seed paper's rig:
// scan*.pcd, the part's mesh, and nominal.json with where the part was placed by hand and the difference
// the LiDAR mount's later calibration found). For each scan: found or not and why, the pose against the
// placement (raw, and after the calibration difference), split-half repeatability (the points split in
// two interleaved halves, each localized alone: the largest distance between where the two poses put the
// seams), the paper's pipeline on the same scan, and every other part's mesh sought in it (all must be
// refused).
#pragma once

#include <string>
#include <vector>

namespace weldtwin {

/// Runs the checks on every scan of `dir` and prints them; `part_spec` gives the seams (its mesh in the
/// same frame as the directory's up to a lift in z); `impostor_meshes` are sought too. Returns the number of
/// scans whose checks failed (not found, a wrong part accepted, or a half-split beyond 0.5 mm).
int check_real_scans(const std::string& dir, const std::string& part_spec,
                     const std::vector<std::string>& impostor_meshes, bool paper);

}  // namespace weldtwin
