// Part specs (YAML). A valid mesh lies beside the spec as part.stl, so that specs naming it get past the
// mesh check into the seams.
#include <filesystem>

#include "core/part_spec.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool mesh = [] {
    std::filesystem::copy_file(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/parts/tube_on_plate.stl",
                               weldtwin::fuzz::scratch("part.stl"),
                               std::filesystem::copy_options::overwrite_existing);
    return true;
  }();
  (void)mesh;
  const std::string path = weldtwin::fuzz::write("spec.yaml", data, size);
  return weldtwin::fuzz::expect_input_errors_only([&] { weldtwin::PartSpec::load(path); });
}
