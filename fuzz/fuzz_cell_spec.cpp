// Cell specs (YAML). The input is written as cells/cell.yaml in a scratch tree whose parts/, robots/ and
// sweeps/ are the repository's scenes (and the default MJCF beside it), so that specs naming them get past
// the file checks. Bad input must end in InputError.
#include <filesystem>

#include "core/cell_spec.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace fs = std::filesystem;
  static const bool tree = [] {
    const fs::path scenes = fs::path(WELDTWIN_SOURCE_DIR) / "scenes";
    const fs::path root = weldtwin::fuzz::scratch("tree");
    fs::create_directories(root / "cells");
    for (const char* d : {"parts", "robots", "sweeps"})
      if (!fs::exists(root / d)) fs::create_directory_symlink(scenes / d, root / d);
    fs::copy_file(scenes / "cells" / "default.xml", root / "cells" / "default.xml",
                  fs::copy_options::overwrite_existing);
    return true;
  }();
  (void)tree;
  const std::string path = weldtwin::fuzz::write("tree/cells/cell.yaml", data, size);
  return weldtwin::fuzz::expect_input_errors_only([&] { weldtwin::CellSpec::load(path); });
}
