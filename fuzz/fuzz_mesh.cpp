// Part meshes (STL, PLY, OBJ): the first byte picks the extension, the rest is the file.
#include "fuzz/fuzz_file.hpp"
#include "perception/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const char* names[3] = {"in.stl", "in.ply", "in.obj"};
  const std::string path = weldtwin::fuzz::write(names[data[0] % 3], data + 1, size - 1);
  return weldtwin::fuzz::expect_input_errors_only([&] { weldtwin::load_mesh(path); });
}
