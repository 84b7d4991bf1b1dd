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

/// The path's extension in lower case, with its dot (".stl"); "" when there is none.
inline std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return ext;
}

}  // namespace weldtwin
