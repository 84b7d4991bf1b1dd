// Part specs (YAML). A valid mesh (tube_on_plate) lies beside the spec as part.obj and part.stl, so that
// specs naming it get past the mesh checks into the seams.
#include <filesystem>
#include <fstream>

#include "core/mesh_file.hpp"
#include "core/part_spec.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // The spec now reads its mesh: part.obj (our own reader, fast) for the seeds, part.stl for older corpora.
  static const bool mesh = [] {
    const std::string stl = std::string(WELDTWIN_SOURCE_DIR) + "/scenes/parts/tube_on_plate.stl";
    std::filesystem::copy_file(stl, weldtwin::fuzz::scratch("part.stl"),
                               std::filesystem::copy_options::overwrite_existing);
    const weldtwin::Mesh m = weldtwin::load_mesh(stl);
    std::ofstream obj(weldtwin::fuzz::scratch("part.obj"));
    obj.precision(17);
    for (const auto& v : m.vertices) obj << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& f : m.faces) obj << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
    return true;
  }();
  (void)mesh;
  const std::string path = weldtwin::fuzz::write("spec.yaml", data, size);
  return weldtwin::fuzz::expect_input_errors_only([&] { weldtwin::PartSpec::load(path); });
}
