// Command line of the survey tools: [--layouts N] [--seed S] CELL.yaml...
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace weldtwin {

struct SurveyArgs {
  int layouts = 50;
  uint64_t seed = 1;
  std::vector<std::string> cells;
  bool help = false;

  /// Parses argv; prints the usage of `tool` for --help (then `help` is set).
  SurveyArgs(int argc, char** argv, const char* tool, int default_layouts) : layouts(default_layouts) {
    for (int i = 1; i < argc; ++i) {
      if (!std::strcmp(argv[i], "--layouts") && i + 1 < argc) {
        layouts = std::atoi(argv[++i]);
      } else if (!std::strcmp(argv[i], "--seed") && i + 1 < argc) {
        seed = std::strtoull(argv[++i], nullptr, 10);
      } else if (!std::strcmp(argv[i], "--help")) {
        std::printf("usage: %s [--layouts N] [--seed S] CELL.yaml...\n", tool);
        help = true;
      } else {
        cells.push_back(argv[i]);
      }
    }
  }
};

}  // namespace weldtwin
