// What the HTML pages of weldtwin (the run report, the benchmark report) share: a self-contained page (no
// network: pictures embedded as data URIs), its style, escaping, number formatting, and gnuplot.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace weldtwin::html {

std::string escape(const std::string& s);
/// `v` with `digits` decimals.
std::string num(double v, int digits = 3);
std::string base64(const std::vector<uint8_t>& bytes);
std::vector<uint8_t> read_bytes(const std::string& path);

/// `<!DOCTYPE html>` .. `<body>` with the shared style sheet.
std::string page_head(const std::string& title);
/// A figure with the PNG file `dir/file` embedded.
std::string figure(const std::string& dir, const std::string& file, const std::string& title,
                   const std::string& caption);

/// Runs gnuplot on `script` (written to `dir/script_name`); false when gnuplot failed or is missing (its
/// messages are in dir/<script_name>.log).
bool gnuplot(const std::string& dir, const std::string& script_name, const std::string& script);

}  // namespace weldtwin::html
