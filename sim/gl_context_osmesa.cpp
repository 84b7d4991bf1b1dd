#include <GL/osmesa.h>
#include <dlfcn.h>

#include <stdexcept>
#include <vector>

#include "sim/gl_context.hpp"

namespace weldtwin {

namespace {

constexpr GLint kDepthBits = 24, kStencilBits = 8, kAccumBits = 0;

// OSMesa, opened when the first picture is made: linked into the executable, it (and the LLVM it brings)
// costs every weldtwin process ~40 ms of start-up, though most never draw. Opened RTLD_GLOBAL, so that
// MuJoCo's renderer finds OSMesa's GL entry points the way it does when OSMesa is linked.
struct OsMesa {
  decltype(&OSMesaCreateContextExt) create = nullptr;
  decltype(&OSMesaMakeCurrent) make_current = nullptr;
  decltype(&OSMesaDestroyContext) destroy = nullptr;
};

const OsMesa& osmesa() {
  static const OsMesa api = [] {
    OsMesa a;
    void* lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_GLOBAL);
    if (!lib) lib = dlopen("libOSMesa.so", RTLD_NOW | RTLD_GLOBAL);
    if (!lib) return a;
    a.create = reinterpret_cast<decltype(a.create)>(dlsym(lib, "OSMesaCreateContextExt"));
    a.make_current = reinterpret_cast<decltype(a.make_current)>(dlsym(lib, "OSMesaMakeCurrent"));
    a.destroy = reinterpret_cast<decltype(a.destroy)>(dlsym(lib, "OSMesaDestroyContext"));
    if (!a.create || !a.make_current || !a.destroy) a = OsMesa();
    return a;
  }();
  if (!api.create)
    throw std::runtime_error(
        "offscreen pictures need OSMesa (libOSMesa.so.8, Debian's libosmesa6): not found");
  return api;
}

}  // namespace

struct OffscreenGlContext::Impl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;
  int width = 0, height = 0;
};

OffscreenGlContext::OffscreenGlContext(int width, int height) : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  r.width = width;
  r.height = height;
  r.context = osmesa().create(OSMESA_RGBA, kDepthBits, kStencilBits, kAccumBits, nullptr);
  if (!r.context) throw std::runtime_error("OSMesa: cannot create a context");
  r.buffer.resize(static_cast<size_t>(width) * static_cast<size_t>(height) * 4);
  if (!osmesa().make_current(r.context, r.buffer.data(), GL_UNSIGNED_BYTE, width, height)) {
    osmesa().destroy(r.context);
    throw std::runtime_error("OSMesa: cannot make the context current");
  }
}

OffscreenGlContext::~OffscreenGlContext() {
  osmesa().destroy(impl_->context);
}

void OffscreenGlContext::make_current() {
  osmesa().make_current(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, impl_->width, impl_->height);
}

}  // namespace weldtwin
