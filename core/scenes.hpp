// Where weldtwin finds its own scenes (cells, parts, robots, sweeps) at run time, not through the path it was
// built in: $WELDTWIN_SCENES when set; else share/weldtwin/scenes beside the executable's directory (the
// install tree: PREFIX/bin/weldtwin and PREFIX/share/weldtwin/scenes; the build tree holds the same link to
// the checkout's scenes/).
#pragma once

#include <string>

namespace weldtwin {

/// The scenes directory. Throws InputError saying where it looked when there is none.
std::string scenes_dir();

/// A file of the scenes: scenes_dir() + "/" + relative (e.g. "cells/default.yaml").
std::string scene_file(const std::string& relative);

/// The cell file given, or the default cell of the scenes when none was ("").
inline std::string cell_or_default(const std::string& cell) {
  return cell.empty() ? scene_file("cells/default.yaml") : cell;
}

}  // namespace weldtwin
