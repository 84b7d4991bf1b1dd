// Errors that cross layer boundaries. Library code reports failures as values where a caller can act on them;
// it throws only for bad input (a file or value the user gave that cannot be used), which the command line
// turns into one line on stderr and exit code 2.
#pragma once

#include <stdexcept>
#include <string>

namespace weldtwin {

/// Bad input: a malformed, missing or impossible file or value. The message names the file and the problem.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Builds "FILE: what" so every input error names its source the same way.
inline InputError input_error(const std::string& file, const std::string& what) {
  return InputError(file + ": " + what);
}

}  // namespace weldtwin
