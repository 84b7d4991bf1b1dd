#include "core/scenes.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "core/error.hpp"

namespace weldtwin {

namespace fs = std::filesystem;

std::string scenes_dir() {
  std::error_code ec;
  if (const char* env = std::getenv("WELDTWIN_SCENES"); env && *env) {
    if (!fs::is_directory(env, ec))
      throw InputError(
          std::string("WELDTWIN_SCENES=") + env +
          ": no such directory (it names weldtwin's scenes: " + "cells/, parts/, robots/, sweeps/)");
    return env;
  }
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  const fs::path beside = ec ? fs::path() : exe.parent_path().parent_path() / "share" / "weldtwin" / "scenes";
  if (!beside.empty() && fs::is_directory(beside, ec)) return beside.string();
  throw InputError(
      "weldtwin's scenes are not installed beside it (looked for " +
      (beside.empty() ? std::string("share/weldtwin/scenes") : beside.string()) +
      "): run it from its install or build tree, or set WELDTWIN_SCENES to the scenes directory");
}

std::string scene_file(const std::string& relative) {
  return scenes_dir() + "/" + relative;
}

}  // namespace weldtwin
