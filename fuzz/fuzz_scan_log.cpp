// ScanLogs (weldtwin's sweep recordings: a header line of JSON, a binary body).
#include "core/scan_log.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = weldtwin::fuzz::write("in.scanlog", data, size);
  return weldtwin::fuzz::expect_input_errors_only([&] { weldtwin::ScanLog::read(path); });
}
