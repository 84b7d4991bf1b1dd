// PCD and PLY clouds: the first byte picks the extension, the rest is the file.
#include "core/cloud_io.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path = weldtwin::fuzz::write(data[0] % 2 ? "in.ply" : "in.pcd", data + 1, size - 1);
  return weldtwin::fuzz::expect_input_errors_only([&] {
    std::vector<weldtwin::Vec3> vps;
    size_t dropped = 0;
    weldtwin::read_cloud(path, &dropped, &vps);
  });
}
