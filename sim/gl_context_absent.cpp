// The GL context of a build without OSMesa (WELDTWIN_WITH_OSMESA=OFF): no pictures, said so.
#include <stdexcept>

#include "sim/gl_context.hpp"

namespace weldtwin {

struct OffscreenGlContext::Impl {};

OffscreenGlContext::OffscreenGlContext(int, int) {
  throw std::runtime_error(
      "built without OSMesa support (WELDTWIN_WITH_OSMESA=OFF): no offscreen pictures; configure with "
      "-DWELDTWIN_WITH_OSMESA=ON for them");
}

OffscreenGlContext::~OffscreenGlContext() = default;

void OffscreenGlContext::make_current() {}

}  // namespace weldtwin
