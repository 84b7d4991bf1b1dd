#include "app/command_line.hpp"

#include <malloc.h>

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
