// `weldtwin calibrate`: the LiDAR's mount on its link from one sweep of the calibration cell (the bare table
// and a known box), written as a correction to the URDF's mount. In the twin, `--mount-error-*` sweeps
// through a deliberately wrong mount, and the command says how well it was recovered.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

struct CalibrateCommand {
  std::string cell;                                     ///< "" = scenes/cells/calibration.yaml
  std::string source = "sim";                           ///< sim | log:FILE (hw/scan_source.hpp)
  std::optional<uint64_t> seed;                         ///< LiDAR noise seed of the twin's sweep
  std::vector<double> mount_error_mm, mount_error_deg;  ///< twin only: the wrong mount to sweep through
  std::string out;                                      ///< mount JSON to write
  std::string urdf_out;  ///< "" = none: the robot URDF with the calibrated mount, all else as it was
  bool quiet = false;
};

/// 0: calibrated; 3: the fit is not to be trusted (the report says why). Throws InputError for bad input.
int run_calibrate(const CalibrateCommand& cmd);

}  // namespace weldtwin
