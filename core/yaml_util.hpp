// Reading YAML specs with errors that name the file and the field. Keys may carry their unit as a suffix
// (docs/design.md): lengths as NAME_m or NAME_mm, angles as NAME_deg or NAME_rad, speeds as NAME_m_s or
// NAME_mm_s.
#pragma once

#include <yaml-cpp/yaml.h>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin::yaml {

/// Loads a YAML file; throws InputError for a missing, unreadable, empty or malformed file.
YAML::Node load_file(const std::string& path);

/// A required scalar; throws InputError "FILE: field 'key' ...".
double number(const YAML::Node& node, const std::string& key, const std::string& file);
std::string text(const YAML::Node& node, const std::string& key, const std::string& file);
/// An optional scalar.
std::optional<double> maybe_number(const YAML::Node& node, const std::string& key, const std::string& file);

/// A length in metres from KEY_m or KEY_mm (or KEY, taken as metres).
std::optional<double> maybe_length(const YAML::Node& node, const std::string& key, const std::string& file);
double length(const YAML::Node& node, const std::string& key, const std::string& file);
/// An angle in radians from KEY_deg or KEY_rad.
std::optional<double> maybe_angle(const YAML::Node& node, const std::string& key, const std::string& file);
double angle(const YAML::Node& node, const std::string& key, const std::string& file);

/// A list of exactly n numbers.
std::vector<double> numbers(const YAML::Node& node, const std::string& key, size_t n,
                            const std::string& file);
Vec3 vec3(const YAML::Node& node, const std::string& key, const std::string& file);

/// Resolves a path given in a YAML file relative to that file's folder.
std::string resolve(const std::string& yaml_file, const std::string& relative);

}  // namespace weldtwin::yaml
