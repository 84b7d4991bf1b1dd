#include "app/plan_files.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.hpp"

namespace weldtwin {

namespace {

constexpr double kMaxSampleGap = 1.0;  // plans are sampled at 200 Hz: samples a second apart are no plan [s]
constexpr long long kMaxSeams = 1 << 20;       // a seam index beyond any part's
constexpr size_t kMinWeldSamples = 2;          // a seam is welded over at least two samples
constexpr double kQuaternionTolerance = 1e-3;  // a written quaternion's length may be off 1 by this much

// A JSON file, or InputError naming it ("cannot open the `what` file", "malformed JSON: ...").
nlohmann::json read_json_file(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw input_error(path, "cannot open the " + what + " file");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw input_error(path, std::string("malformed JSON: ") + e.what());
  }
}

}  // namespace

// A pose JSON: {"T_base_part": [[4x4 row-major]], ...} (docs/design.md).
Iso3 read_pose(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "pose");
  if (j.is_object() && j.contains("found") && j["found"] == false) {
    const std::string why =
        j.contains("reason") && j["reason"].is_string() ? j["reason"].get<std::string>() : "";
    throw input_error(path, "the pose says the part was not found" + (why.empty() ? "" : " (" + why + ")") +
                                ": localize it again before planning");
  }
  if (!j.contains("T_base_part")) throw input_error(path, "no field 'T_base_part'");
  const auto& m = j["T_base_part"];
  if (!m.is_array() || m.size() != 4) throw input_error(path, "T_base_part must be a 4x4 array");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    if (!m[static_cast<size_t>(r)].is_array() || m[static_cast<size_t>(r)].size() != 4)
      throw input_error(path, "T_base_part must be a 4x4 array");
    for (int c = 0; c < 4; ++c) {
      const auto& v = m[static_cast<size_t>(r)][static_cast<size_t>(c)];
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw input_error(path, "T_base_part has a non-number");
      M(r, c) = v.get<double>();
    }
  }
  Iso3 T;
  T.matrix() = M;
  if ((T.linear() * T.linear().transpose() - Mat3::Identity()).norm() > 1e-6 ||
      T.linear().determinant() < 0 || (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
    throw input_error(path, "T_base_part is not a rigid transform");
  return orthonormalized(T);
}

WeldPlan read_plan(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "plan");
  if (!j.is_object() || !j.contains("samples") || !j["samples"].is_array() || j["samples"].empty())
    throw input_error(path, "no samples (a plan as weldtwin plan writes it)");
  WeldPlan plan;
  double t_prev = -1.0;
  size_t k = 0;
  for (const auto& s : j["samples"]) {
    const std::string at = "sample " + std::to_string(k++);
    if (!s.is_object() || !s.contains("t") || !s.contains("q") || !s["t"].is_number() || !s["q"].is_array() ||
        s["q"].size() != 6)
      throw input_error(path, at + ": needs t and q[6]");
    PlanSample p;
    p.t_s = s["t"].get<double>();
    for (int i = 0; i < 6; ++i) {
      const auto& v = s["q"][static_cast<size_t>(i)];
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw input_error(path, at + ": q has a non-number");
      p.q[i] = v.get<double>();
    }
    if (!std::isfinite(p.t_s) || p.t_s <= t_prev || p.t_s < 0.0)
      throw input_error(path, at + ": times must start at 0 or later and increase");
    if (t_prev >= 0.0 && p.t_s - t_prev > kMaxSampleGap)
      throw input_error(path, at + ": " + std::to_string(p.t_s - t_prev) +
                                  " s after the one before (weldtwin plan writes 200 samples a second)");
    t_prev = p.t_s;
    if (s.contains("tcp") && s["tcp"].is_array() && s["tcp"].size() == 7) {
      const auto& c = s["tcp"];
      for (const auto& v : c)
        if (!v.is_number() || !std::isfinite(v.get<double>()))
          throw input_error(path, at + ": tcp has a non-number");
      const double norm =
          std::sqrt(c[3].get<double>() * c[3].get<double>() + c[4].get<double>() * c[4].get<double>() +
                    c[5].get<double>() * c[5].get<double>() + c[6].get<double>() * c[6].get<double>());
      if (!(std::abs(norm - 1.0) < kQuaternionTolerance))
        throw input_error(path, at + ": tcp's quaternion (w x y z) is not of unit length");
      p.T_base_tcp =
          make_transform(Vec3(c[0].get<double>(), c[1].get<double>(), c[2].get<double>()),
                         Quat(c[3].get<double>(), c[4].get<double>(), c[5].get<double>(), c[6].get<double>())
                             .normalized()
                             .toRotationMatrix());
    }
    if (s.contains("seam") && (!s["seam"].is_number_integer() || s["seam"].get<long long>() < -1 ||
                               s["seam"].get<long long>() > kMaxSeams))
      throw input_error(path, at + ": seam must be a seam's index or -1");
    if (s.contains("arc") && !s["arc"].is_boolean())
      throw input_error(path, at + ": arc must be true or false");
    p.seam = s.value("seam", -1);
    p.arc = s.value("arc", false);
    plan.samples.push_back(p);
  }
  return plan;
}

void check_plan_for_part(const WeldPlan& plan, const PartSpec& part, const std::string& path) {
  std::vector<size_t> welded(part.seams.size(), 0);
  for (size_t k = 0; k < plan.samples.size(); ++k) {
    const PlanSample& s = plan.samples[k];
    if (s.seam >= static_cast<int>(part.seams.size()))
      throw input_error(path, "sample " + std::to_string(k) + " names seam " + std::to_string(s.seam) +
                                  "; part '" + part.name + "' has " + std::to_string(part.seams.size()));
    if (s.arc && s.seam >= 0) ++welded[static_cast<size_t>(s.seam)];
  }
  for (size_t i = 0; i < welded.size(); ++i)
    if (welded[i] < kMinWeldSamples)
      throw input_error(path, "the plan does not weld seam '" + part.seams[i].name + "' of part '" +
                                  part.name + "' (" + std::to_string(welded[i]) + " arc-on samples)");
}

}  // namespace weldtwin
