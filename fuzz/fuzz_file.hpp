// The readers take paths: each input is written to a file of its own under /dev/shm (or the temp dir) first.
// Bad input must end in InputError; anything else (a signal, a sanitizer report, another exception) is a
// finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.hpp"

namespace weldtwin::fuzz {

inline std::string scratch(const std::string& name) {
  static const std::filesystem::path dir = [] {
    std::filesystem::path d =
        std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    d /= "weldtwin_fuzz_" + std::to_string(getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return (dir / name).string();
}

inline std::string write(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = scratch(name);
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

// Runs f; InputError is the expected answer to bad input, every other exception is a finding.
template <class F>
int expect_input_errors_only(F&& f) {
  try {
    f();
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace weldtwin::fuzz
