// The slots of a 3D lookup grid that is filled as it is asked: all zero at first, kept in bricks of 4 x 4 x 4
// cells that are made when a cell of theirs is first asked about, side by side in 2 MB pages.
//
// The localizer's lookup grids span tens of megabytes around the part, and a localization asks about a
// tenth of them, scattered. In one flat array every page that a question lands on is made on its first
// write: as 4 kB pages two faults and an interrupt to every core each, as 2 MB pages a clear of 2 MB each
// (55 MB a localization, a sixth of its time on a virtual machine). Bricks hold only the neighbourhoods that
// are asked about (4 MB of them, not 55), packed in the order they are made into 2 MB pages
// (zeroed_slots.hpp): a page fault per 2 MB of them.
#pragma once

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "perception/localize/zeroed_slots.hpp"

namespace weldtwin {

template <class T>  // an integer or a pointer (all bits zero is its zero)
class BrickSlots {
 public:
  static constexpr int kEdgeBits = 2;  ///< bricks of 2^2 = 4 cells along each axis
  static constexpr long kEdge = 1L << kEdgeBits;
  static constexpr size_t kBrickSlots = size_t{1} << (3 * kEdgeBits);
  static constexpr size_t kChunkBricks = kHugePageArray_bytes / (kBrickSlots * sizeof(T));

  BrickSlots() = default;
  /// A grid of nx x ny x nz cells (each at least 1), every slot zero; throws std::bad_alloc when the system
  /// refuses.
  BrickSlots(long nx, long ny, long nz)
      : bx_((nx + kEdge - 1) >> kEdgeBits),
        by_((ny + kEdge - 1) >> kEdgeBits),
        bz_((nz + kEdge - 1) >> kEdgeBits) {
    if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("BrickSlots: a grid needs a cell each way");
    // At least a huge page's worth: a first read of a small page maps the zero page, its first write copies
    // it (two faults where one 2 MB page makes one).
    const size_t n = static_cast<size_t>(bx_) * static_cast<size_t>(by_) * static_cast<size_t>(bz_);
    bricks_ = zeroed_slots<T*>(std::max(n, kHugePageArray_bytes / sizeof(T*)));
  }
  BrickSlots(BrickSlots&& other) noexcept { *this = std::move(other); }
  BrickSlots& operator=(BrickSlots&& other) noexcept {
    bx_ = other.bx_, by_ = other.by_, bz_ = other.bz_;
    bricks_ = std::move(other.bricks_);
    chunks_ = std::move(other.chunks_);
    used_ = other.used_;
    other.used_ = kChunkBricks;
    return *this;
  }
  BrickSlots(const BrickSlots&) = delete;
  BrickSlots& operator=(const BrickSlots&) = delete;

  /// The slot of cell (ix, iy, iz), inside the grid: its brick is made (all zero) on the first ask. Safe to
  /// call from several threads; the slot itself is the caller's to read and write (atomically, when shared).
  T* slot(long ix, long iy, long iz) {
    T* brick = made_brick(
        static_cast<size_t>(((iz >> kEdgeBits) * by_ + (iy >> kEdgeBits)) * bx_ + (ix >> kEdgeBits)));
    constexpr long m = kEdge - 1;
    return brick + (((iz & m) << (2 * kEdgeBits)) | ((iy & m) << kEdgeBits) | (ix & m));
  }

  /// How many bricks the grid has room for; brick b holds cells (x, y, z) / kEdge = (b % bx, b / bx % by,
  /// b / (bx by)), its slots in the order x fastest.
  size_t brick_capacity() const {
    return static_cast<size_t>(bx_) * static_cast<size_t>(by_) * static_cast<size_t>(bz_);
  }
  /// Brick b's kBrickSlots slots (b < brick_capacity()), or null when it has not been made.
  const T* brick(size_t b) const { return __atomic_load_n(&bricks_[b], __ATOMIC_ACQUIRE); }
  /// The same, made (all zero) when missing. Safe to call from several threads.
  T* made_brick(size_t b) {
    T** at = &bricks_[b];
    T* brick = __atomic_load_n(at, __ATOMIC_ACQUIRE);
    if (brick) return brick;
    const std::lock_guard<std::mutex> lock(making_);
    brick = __atomic_load_n(at, __ATOMIC_ACQUIRE);  // made meanwhile by another thread?
    if (!brick) {
      if (used_ == kChunkBricks) {
        chunks_.push_back(zeroed_slots<T>(kChunkBricks * kBrickSlots));
        used_ = 0;
      }
      brick = chunks_.back().get() + kBrickSlots * used_++;
      __atomic_store_n(at, brick, __ATOMIC_RELEASE);
    }
    return brick;
  }

  /// How many bricks have been made (what the grid holds: this x kBrickSlots slots).
  size_t bricks_made() const { return chunks_.empty() ? 0 : (chunks_.size() - 1) * kChunkBricks + used_; }

 private:
  long bx_ = 0, by_ = 0, bz_ = 0;
  ZeroedSlots<T*> bricks_;  ///< per brick: its first slot, or null until made
  std::mutex making_;
  std::vector<ZeroedSlots<T>> chunks_;  ///< the bricks, kChunkBricks to a 2 MB chunk
  size_t used_ = kChunkBricks;          ///< bricks handed out of the last chunk
};

}  // namespace weldtwin
