// An array of slots that starts all zero, straight from the system's zeroed pages: a lookup grid of tens of
// megabytes costs only the pages that are asked about, not a write of all of it up front.
//
// The grids are filled as they are asked: a slot is read, and written when it was still zero. The first read
// of a 4 kB page maps the system's shared zero page; the write that follows makes a private copy and has
// every other thread of the process drop the old mapping from its TLB (an interrupt to each core): two
// faults and a round of interrupts per page, about 20,000 of them in one localization (a third of it on a
// virtual machine). Large arrays are therefore asked for as 2 MB pages where the system allows
// (MADV_HUGEPAGE; transparent huge pages "madvise" or "always"): one such round per 512 small pages. Where it
// does not, the array is as before, page by page.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>

namespace weldtwin {

/// Returns a mapping of ZeroedSlots to the system.
struct FreeSlots {
  void* mapping = nullptr;
  size_t bytes = 0;
  void operator()(void*) const {
    if (mapping) munmap(mapping, bytes);
  }
};

template <class T>
using ZeroedSlots = std::unique_ptr<T[], FreeSlots>;

/// Arrays at least this large (one huge page) are given 2 MB pages where the system allows.
constexpr size_t kHugePageArray_bytes = size_t{2} << 20;

/// `n` slots of T, all bits zero (T: an integer or a pointer); throws std::bad_alloc when the system refuses.
template <class T>
ZeroedSlots<T> zeroed_slots(size_t n) {
  constexpr size_t kHuge = kHugePageArray_bytes;  // the huge page's size and alignment
  if (n == 0) n = 1;
  if (n > SIZE_MAX / sizeof(T) - kHuge) throw std::bad_alloc();
  const size_t want = n * sizeof(T);
  const bool huge = want >= kHugePageArray_bytes;
  // A huge page needs a 2 MB aligned range: map 2 MB more and start at the first boundary.
  const size_t bytes = huge ? want + kHuge : want;
  void* mapping = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (mapping == MAP_FAILED) throw std::bad_alloc();
  auto* start = static_cast<unsigned char*>(mapping);
  if (huge) {
    const uintptr_t at = reinterpret_cast<uintptr_t>(mapping);
    start += (kHuge - at % kHuge) % kHuge;
    madvise(start, want, MADV_HUGEPAGE);  // advice: refused (no THP here), the small pages serve
  }
  return ZeroedSlots<T>(reinterpret_cast<T*>(start), FreeSlots{mapping, bytes});
}

}  // namespace weldtwin
