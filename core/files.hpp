// Questions about a path the user gave, answered without throwing: a name too long or a component that is not
// a directory is "no such file" (the caller says so naming the file), not a filesystem_error.
#pragma once

#include <filesystem>
#include <string>
#include <system_error>

namespace weldtwin {

inline bool is_file(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}

inline bool path_exists(const std::string& path) {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

}  // namespace weldtwin
