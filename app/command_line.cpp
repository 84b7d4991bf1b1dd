#include "app/command_line.hpp"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/error.hpp"
#include "pipeline/outcome.hpp"

namespace weldtwin {

void keep_freed_memory_for_reuse() {
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
  mallopt(M_TOP_PAD, 16 << 20);
}

void heap_in_huge_pages() {
  constexpr size_t kHeap = size_t{64} << 20;
  constexpr uintptr_t kHuge = uintptr_t{2} << 20;
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kHeap));
  mallopt(M_TRIM_THRESHOLD, static_cast<int>(kHeap));
  mallopt(M_TOP_PAD, static_cast<int>(kHeap));
  mallopt(M_ARENA_MAX, 1);
  void* first = malloc(size_t{8} << 20);  // more than the heap has free: it grows by this and the top pad
  const uintptr_t lo = (reinterpret_cast<uintptr_t>(first) + kHuge - 1) & ~(kHuge - 1),
                  hi = reinterpret_cast<uintptr_t>(sbrk(0)) & ~(kHuge - 1);
  if (first && hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
  free(first);
}

int parse_command_line(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "weldtwin: %s (see --help)\n", e.what());
    return kExitBadInput;
  }
  return -1;
}

int exit_code_for(const std::exception& e) {
  if (dynamic_cast<const InputError*>(&e)) {
    std::fprintf(stderr, "weldtwin: %s\n", e.what());
    return kExitBadInput;
  }
  std::fprintf(stderr, "weldtwin: internal error: %s\n", e.what());
  return 1;
}

}  // namespace weldtwin
