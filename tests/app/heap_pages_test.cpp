// heap_in_huge_pages (app/command_line.hpp): after it, the process's heap is eligible for 2 MB pages where
// the system gives them, and memory allocated and touched there comes in 2 MB pages (AnonHugePages).
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "app/command_line.hpp"

namespace weldtwin {
namespace {

// A field of /proc/self/smaps summed over the heap's mappings (a heap of several: madvise splits it), -1
// when there is none.
long heap_field(const std::string& name) {
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool heap = false, any = false;
  long sum = 0;
  while (std::getline(in, line)) {
    const size_t dash = line.find('-'), space = line.find(' ');
    if (dash != std::string::npos && space != std::string::npos && dash < space &&
        line.find_first_not_of("0123456789abcdef") == dash) {
      heap = line.find("[heap]") != std::string::npos;
      any = any || heap;
    } else if (heap && line.rfind(name + ":", 0) == 0) {
      sum += std::stol(line.substr(name.size() + 1));
    }
  }
  return any ? sum : -1;
}

TEST(HeapPages, TheHeapIsAskedForInHugePages) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "under AddressSanitizer memory comes from its own allocator, not the heap";
#endif
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(thp, mode);
  if (mode.find("[never]") != std::string::npos || mode.empty())
    GTEST_SKIP() << "this system gives no transparent huge pages (" << mode << ")";
  heap_in_huge_pages();
  ASSERT_GE(heap_field("Size"), 64 * 1024) << "the heap was not grown";
  const long huge_before = heap_field("AnonHugePages");
  // 16 MB allocated from it and touched: in 2 MB pages (at least one: a system short of free 2 MB blocks may
  // give 4 kB pages for some of it; without the advice this heap gets none).
  std::vector<char> block(size_t{16} << 20);
  std::memset(block.data(), 1, block.size());
  EXPECT_GE(heap_field("AnonHugePages") - huge_before, 2 * 1024);
}

}  // namespace
}  // namespace weldtwin
