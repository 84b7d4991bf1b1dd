// `weldtwin localize`: find the part's mesh in a base-frame cloud of a table scene and write the pose JSON.
#pragma once

#include <string>
#include <vector>

namespace weldtwin {

struct LocalizeCommand {
  std::string model;            ///< part mesh (STL, PLY, OBJ)
  std::string scan;             ///< cloud (PCD, PLY), base frame
  std::vector<double> roi;      ///< empty, or xmin ymin zmin xmax ymax zmax [m]
  std::string units = "m";      ///< mesh units: m or mm
  std::string part;             ///< optional part spec: its seams decide which symmetric poses are equivalent
  std::string method = "ours";  ///< ours, or paper (the published pipeline, the benchmarks' baseline)
  std::string out;
  bool quiet = false;
};

/// Returns 0 when found, 3 when the part is absent, ambiguous or poorly fitted (the JSON says why).
int run_localize(const LocalizeCommand& cmd);

}  // namespace weldtwin
