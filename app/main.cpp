// weldtwin: the command line. `weldtwin localize` is answered here, by a program that loads only what a
// localization needs (17 shared libraries); every other command belongs to weldtwin-cell
// (app/cell_main.cpp: MuJoCo, the planners, the robot driver, ROS bags; 49 libraries), installed beside this
// program, which hands the command over by becoming it (exec: the same process, arguments and exit code).
// Loading the cell's libraries took 35-40 ms of a 0.25 s localization. Exit codes: 0 done, 2 bad input (one
// line on stderr naming the file and the problem), 3 the answer is not trustworthy, 1 an internal error.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <string>
#include <system_error>

#include "app/command_line.hpp"
#include "app/localize_command.hpp"

namespace {

// weldtwin-cell beside this program.
std::string cell_program() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ((ec ? std::filesystem::path() : self.parent_path()) / "weldtwin-cell").string();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "localize") != 0) {
    const std::string cell = cell_program();
    execv(cell.c_str(), argv);
    std::fprintf(stderr, "weldtwin: cannot run %s (weldtwin's commands but localize): %s\n", cell.c_str(),
                 std::strerror(errno));
    return 1;
  }
  weldtwin::heap_in_huge_pages();
  CLI::App app;
  weldtwin::describe_weldtwin(app);
  app.require_subcommand(1);
  weldtwin::LocalizeCommand localize;
  weldtwin::add_localize_command(app, localize);
  if (const int code = weldtwin::parse_command_line(app, argc, argv); code >= 0) return code;
  try {
    return weldtwin::run_localize(localize);
  } catch (const std::exception& e) {
    return weldtwin::exit_code_for(e);
  }
}
