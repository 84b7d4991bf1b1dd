// Where the tests find the real files made outside the project.
#pragma once

#include <cstdlib>
#include <string>

namespace weldtwin::test {

/// A file among the real files made outside the project (WELDTWIN_REAL_DATA, or ../shared/real beside the
/// repository); tests that use them skip, saying so, where they are absent.
inline std::string real_data(const std::string& relative) {
  const char* env = std::getenv("WELDTWIN_REAL_DATA");
  return (env ? std::string(env) : std::string(WELDTWIN_SOURCE_DIR) + "/../shared/real") + "/" + relative;
}

}  // namespace weldtwin::test
