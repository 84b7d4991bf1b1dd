#include "app/json_file.hpp"

#include <cmath>
#include <fstream>

#include "core/error.hpp"

namespace weldtwin {

namespace {

constexpr double kRotationTolerance = 1e-6;   // |R R^T - I| of a rotation as written with 17 digits
constexpr double kBottomRowTolerance = 1e-9;  // the last row of a rigid transform is 0 0 0 1

}  // namespace

nlohmann::json read_json_file(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw input_error(path, "cannot open the " + what + " file");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw input_error(path, std::string("malformed JSON: ") + e.what());
  }
}

void write_text_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc | std::ios::binary);
  if (!out) throw input_error(path, "cannot be written");
  out << text;
  out.close();
  if (!out) throw input_error(path, "could not be written whole (disk full?)");
}

void write_json_file(const std::string& path, const nlohmann::json& j, int indent) {
  write_text_file(path, j.dump(indent) + '\n');
}

nlohmann::json transform_json(const Iso3& T) {
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    m.push_back({T.matrix()(r, 0), T.matrix()(r, 1), T.matrix()(r, 2), T.matrix()(r, 3)});
  return m;
}

Iso3 read_transform_json(const nlohmann::json& j, const std::string& field, const std::string& path) {
  if (!j.is_object() || !j.contains(field)) throw input_error(path, "no field '" + field + "'");
  const auto& m = j[field];
  if (!m.is_array() || m.size() != 4) throw input_error(path, field + " must be a 4x4 array");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    const auto& row = m[static_cast<size_t>(r)];
    if (!row.is_array() || row.size() != 4) throw input_error(path, field + " must be a 4x4 array");
    for (int c = 0; c < 4; ++c) {
      const auto& v = row[static_cast<size_t>(c)];
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw input_error(path, field + " has a non-number");
      M(r, c) = v.get<double>();
    }
  }
  Iso3 T;
  T.matrix() = M;
  if ((T.linear() * T.linear().transpose() - Mat3::Identity()).norm() > kRotationTolerance ||
      T.linear().determinant() < 0 ||
      (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > kBottomRowTolerance)
    throw input_error(path, field + " is not a rigid transform");
  return orthonormalized(T);
}

}  // namespace weldtwin
