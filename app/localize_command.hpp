// `weldtwin localize`: find the part's mesh in a base-frame cloud of a table scene and write the pose JSON.
// Its command line is defined here once, for both programs that take it: `weldtwin`, which answers it
// without loading the cell's libraries (app/main.cpp), and `weldtwin-cell`, every command
// (app/cell_main.cpp).
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace CLI {
class App;
}

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
  std::string part_cache;  ///< folder of prepared parts kept between runs ("" before the default is applied)
  bool no_part_cache = false;
  /// Where the cell's table top is (the plane z = this in the base frame) [mm]; NaN: not checked
  double table_top_z_mm = std::numeric_limits<double>::quiet_NaN();
  std::string roi_text;  ///< --roi as given (six numbers, commas between), read into `roi` by run_localize
};

/// Adds the `localize` subcommand and its options, landing in `cmd`.
CLI::App* add_localize_command(CLI::App& app, LocalizeCommand& cmd);

/// weldtwin's description and the footer naming its scenes, for the top level of either program.
void describe_weldtwin(CLI::App& app);

/// Where prepared parts are kept between runs unless told otherwise: $WELDTWIN_PART_CACHE ("off": nowhere),
/// else $XDG_CACHE_HOME/weldtwin/parts, else $HOME/.cache/weldtwin/parts ("" when none of them is set).
std::string default_part_cache_dir();

/// Returns 0 when found, 3 when the part is absent, ambiguous or poorly fitted (the JSON says why); throws
/// InputError on a bad file or option.
int run_localize(LocalizeCommand cmd);

}  // namespace weldtwin
