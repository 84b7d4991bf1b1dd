// JSON files as every command reads and writes them: read with every problem an InputError naming the file,
// written whole or an InputError naming the file (nothing silently lost; text files such as the HTML reports
// the same way), and the one way a rigid transform is written (4x4, row-major, metres).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/geometry.hpp"

namespace weldtwin {

/// The JSON in `path`; InputError "cannot open the `what` file" or "malformed JSON: ..." naming the file.
nlohmann::json read_json_file(const std::string& path, const std::string& what);

/// Writes `j` to `path` (`indent` as nlohmann's dump: -1 one line); InputError naming the file when it
/// cannot be written whole.
void write_json_file(const std::string& path, const nlohmann::json& j, int indent = 1);

/// Writes `text` to `path` as it is; InputError naming the file when it cannot be written whole.
void write_text_file(const std::string& path, const std::string& text);

/// T as a 4x4 row-major array of numbers.
nlohmann::json transform_json(const Iso3& T);

/// The rigid transform of field `field` of `j` (a 4x4 row-major array); InputError naming `path` and the
/// field when it is missing, not 4x4, holds a non-number or is not rigid.
Iso3 read_transform_json(const nlohmann::json& j, const std::string& field, const std::string& path);

}  // namespace weldtwin
