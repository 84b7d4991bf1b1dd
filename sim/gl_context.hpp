// The GL context offscreen pictures are drawn in: OSMesa's software renderer drawing into memory of our own
// (no display, no GPU). A build without OSMesa (WELDTWIN_WITH_OSMESA=OFF) has the same class, whose
// constructor says so.
#pragma once

#include <memory>

namespace weldtwin {

class OffscreenGlContext {
 public:
  /// A context with a width x height RGBA colour buffer and a depth buffer, made current. Throws
  /// std::runtime_error naming what is missing (OSMesa's library, or OSMesa in this build).
  OffscreenGlContext(int width, int height);
  ~OffscreenGlContext();
  OffscreenGlContext(const OffscreenGlContext&) = delete;
  OffscreenGlContext& operator=(const OffscreenGlContext&) = delete;

  /// Makes this the current context of the calling thread again.
  void make_current();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace weldtwin
