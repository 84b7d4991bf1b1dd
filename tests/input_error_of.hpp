// The message of the InputError a call throws ("" if it throws none), for tests of what bad input is told.
#pragma once

#include <functional>
#include <string>

#include "core/error.hpp"

namespace weldtwin::test {

inline std::string input_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace weldtwin::test
