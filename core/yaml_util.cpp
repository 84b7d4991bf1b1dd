#include "core/yaml_util.hpp"

#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "core/files.hpp"

namespace weldtwin::yaml {
namespace {

double as_number(const YAML::Node& v, const std::string& key, const std::string& file) {
  if (!v.IsScalar()) throw input_error(file, "field '" + key + "' must be a number");
  double x = 0.0;
  try {
    x = v.as<double>();
  } catch (const YAML::Exception&) {
    throw input_error(file, "field '" + key + "' must be a number, got '" + v.Scalar() + "'");
  }
  if (!std::isfinite(x)) throw input_error(file, "field '" + key + "' must be finite");
  return x;
}

}  // namespace

YAML::Node load_file(const std::string& path) {
  if (!is_file(path)) throw input_error(path, "no such file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw input_error(path, "malformed YAML at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!root || root.IsNull()) throw input_error(path, "empty file");
  if (!root.IsMap()) throw input_error(path, "expected a mapping at the top level");
  return root;
}

std::optional<double> maybe_number(const YAML::Node& node, const std::string& key, const std::string& file) {
  const YAML::Node v = node[key];
  if (!v) return std::nullopt;
  return as_number(v, key, file);
}

double number(const YAML::Node& node, const std::string& key, const std::string& file) {
  auto v = maybe_number(node, key, file);
  if (!v) throw input_error(file, "missing field '" + key + "'");
  return *v;
}

std::string text(const YAML::Node& node, const std::string& key, const std::string& file) {
  const YAML::Node v = node[key];
  if (!v) throw input_error(file, "missing field '" + key + "'");
  if (!v.IsScalar()) throw input_error(file, "field '" + key + "' must be a string");
  return v.Scalar();
}

std::optional<double> maybe_length(const YAML::Node& node, const std::string& key, const std::string& file) {
  if (auto v = maybe_number(node, key + "_m", file)) return *v;
  if (auto v = maybe_number(node, key + "_mm", file)) return *v * 1e-3;
  return maybe_number(node, key, file);
}

double length(const YAML::Node& node, const std::string& key, const std::string& file) {
  auto v = maybe_length(node, key, file);
  if (!v) throw input_error(file, "missing field '" + key + "_m' (or '" + key + "_mm')");
  return *v;
}

std::optional<double> maybe_angle(const YAML::Node& node, const std::string& key, const std::string& file) {
  if (auto v = maybe_number(node, key + "_rad", file)) return *v;
  if (auto v = maybe_number(node, key + "_deg", file)) return deg2rad(*v);
  return std::nullopt;
}

double angle(const YAML::Node& node, const std::string& key, const std::string& file) {
  auto v = maybe_angle(node, key, file);
  if (!v) throw input_error(file, "missing field '" + key + "_deg' (or '" + key + "_rad')");
  return *v;
}

std::vector<double> numbers(const YAML::Node& node, const std::string& key, size_t n,
                            const std::string& file) {
  const YAML::Node v = node[key];
  if (!v) throw input_error(file, "missing field '" + key + "'");
  if (!v.IsSequence() || v.size() != n)
    throw input_error(file, "field '" + key + "' must be a list of " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const auto& x : v) out.push_back(as_number(x, key, file));
  return out;
}

Vec3 vec3(const YAML::Node& node, const std::string& key, const std::string& file) {
  auto v = numbers(node, key, 3, file);
  return Vec3(v[0], v[1], v[2]);
}

std::string resolve(const std::string& yaml_file, const std::string& relative) {
  std::filesystem::path p(relative);
  if (p.is_absolute()) return p.string();
  return (std::filesystem::path(yaml_file).parent_path() / p).lexically_normal().string();
}

}  // namespace weldtwin::yaml
