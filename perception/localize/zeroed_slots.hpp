// An array of slots that starts all zero, straight from the system's zeroed pages (calloc): a lookup grid of
// tens of megabytes costs only the pages that are asked about, not a write of all of it up front.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>

namespace weldtwin {

struct FreeSlots {
  void operator()(void* p) const { std::free(p); }
};

template <class T>
using ZeroedSlots = std::unique_ptr<T[], FreeSlots>;

/// `n` slots of T, all bits zero (T: an integer or a pointer); throws std::bad_alloc when the system refuses.
template <class T>
ZeroedSlots<T> zeroed_slots(size_t n) {
  ZeroedSlots<T> slots(static_cast<T*>(std::calloc(n, sizeof(T))));
  if (!slots) throw std::bad_alloc();
  return slots;
}

}  // namespace weldtwin
