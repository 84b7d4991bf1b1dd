// What both of weldtwin's programs (weldtwin, weldtwin-cell) do around a command: the allocator's setting,
// the parse, and the exit codes of what a command throws (docs/design.md: 0 done, 2 bad input, 3 refused,
// 1 an internal error).
#pragma once

#include <exception>

namespace CLI {
class App;
}

namespace weldtwin {

/// The allocator keeps what is freed for the next allocation instead of giving it back to the system at
/// once: blocks of 128 kB and more were mapped and unmapped on every use (a localization grows and drops
/// vectors of scan points many times), and each new mapping costs a page fault per page touched, each
/// unmapping an interrupt to every core running one of the process's threads; on a virtual machine that was
/// a tenth of a localization. Blocks up to 64 MB come from the heap; up to 64 MB freed at its top stay.
void keep_freed_memory_for_reuse();

/// The same for a short process that allocates its memory anew, fast: the heap is grown by 64 MB at once and
/// those 64 MB are asked for as 2 MB pages (MADV_HUGEPAGE: the system's transparent huge pages, "madvise" or
/// "always"), every thread allocating from it. A page fault costs about 11 us per 4 kB on this virtual
/// machine and a localization touched some 4,000 pages, a sixth of its CPU time; in 2 MB pages, 1,200
/// faults. Where the system gives no huge pages the heap is as before.
void heap_in_huge_pages();

/// Parses the command line into `app`: -1 when it parsed, else the exit code (help asked for and printed: 0;
/// a wrong option: 2, said in one line on stderr).
int parse_command_line(CLI::App& app, int argc, char** argv);

/// The exit code for what a command threw, said in one line on stderr: 2 for a bad input (InputError),
/// else 1 (an internal error).
int exit_code_for(const std::exception& e);

}  // namespace weldtwin
