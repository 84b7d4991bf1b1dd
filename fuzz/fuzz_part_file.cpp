// Kept prepared parts (perception/localize/part_model_file.hpp): the first byte picks the body parser (the
// part model's, or its lookups' with a grid of 12 x 10 x 8 bricks, no closest-face grid and a model of up to
// 255 samples, from the second byte), the rest is the body. A damaged body must be refused (false) and leave
// the model alone; anything else (a signal, a sanitizer report, an exception) is a finding.
#include <cstdint>
#include <cstdlib>

#include "perception/localize/part_model_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const char* body = reinterpret_cast<const char*>(data + 2);
  const size_t n = size - 2;
  weldtwin::PartModel model;
  if (data[0] % 2 == 0) {
    weldtwin::Mesh rest;
    if (!weldtwin::read_part_model_body(body, n, model, rest) && (!model.pts.empty() || !rest.faces.empty()))
      std::abort();  // refused, yet changed
    for (const auto& f : rest.faces)
      for (int k = 0; k < 3; ++k)
        if (f[k] < 0 || static_cast<size_t>(f[k]) >= rest.vertices.size()) std::abort();
    return 0;
  }
  model.pts.resize(data[1]);
  model.cache = weldtwin::BrickSlots<int>(48, 40, 32);
  if (!weldtwin::read_part_lookups_body(body, n, model, 100) && model.cache.bricks_made() != 0) std::abort();
  return 0;
}
