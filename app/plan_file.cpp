#include "app/plan_file.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "app/json_file.hpp"
#include "core/error.hpp"

namespace weldtwin {

namespace {

constexpr double kMaxSampleGap = 1.0;  // plans are sampled at 200 Hz: samples a second apart are no plan [s]
constexpr long long kMaxSeams = 1 << 20;       // a seam index beyond any part's
constexpr size_t kMinWeldSamples = 2;          // a seam is welded over at least two samples
constexpr double kQuaternionTolerance = 1e-3;  // a written quaternion's length may be off 1 by this much

// The name a plan file gives a sample's phase.
const char* phase_name(Phase phase) {
  switch (phase) {
    case Phase::kTransit:
      return "transit";
    case Phase::kApproach:
      return "approach";
    case Phase::kWeld:
      return "weld";
    case Phase::kCorner:
      return "corner";
    case Phase::kDeparture:
      return "departure";
  }
  return "?";
}

// A pose as the plan file writes the TCP: x y z [m], then the quaternion w x y z.
nlohmann::json tcp_json(const Iso3& T) {
  const Quat q(T.linear());
  return {T.translation().x(), T.translation().y(), T.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

}  // namespace

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

nlohmann::json plan_to_json(const WeldPlan& plan, const PartSpec& part, const RobotModel& robot,
                            const PlanSetting& setting) {
  nlohmann::json out;
  out["part"] = part.name;
  out["robot"] = robot.name();
  out["ok"] = plan.ok();
  out["problems"] = plan.problems;
  out["notes"] = plan.notes;
  out["sample_hz"] = setting.sample_hz;
  out["duration_s"] = plan.duration_s();
  out["T_flange_tcp"] = transform_json(plan.T_flange_tcp);
  for (const PlannedSeam& s : plan.seams) {
    nlohmann::json rolls = nlohmann::json::array();
    for (double r : s.roll_per_piece_rad) rolls.push_back(r * 180.0 / kPi);
    out["seams"].push_back({{"name", s.name},
                            {"start_base", {s.start_base.x(), s.start_base.y(), s.start_base.z()}},
                            {"end_base", {s.end_base.x(), s.end_base.y(), s.end_base.z()}},
                            {"length_m", s.length_m},
                            {"speed_m_s", s.speed_m_s},
                            {"pieces", s.pieces},
                            {"torch_roll_deg", rolls},
                            {"work_angle_deg", s.work_angle_rad * 180.0 / kPi},
                            {"travel_angle_deg", s.travel_angle_rad * 180.0 / kPi},
                            {"reversed", s.reversed}});
  }
  nlohmann::json samples = nlohmann::json::array();
  for (const PlanSample& s : plan.samples)
    samples.push_back({{"t", s.t_s},
                       {"q", {s.q[0], s.q[1], s.q[2], s.q[3], s.q[4], s.q[5]}},
                       {"tcp", tcp_json(s.T_base_tcp)},
                       {"seam", s.seam},
                       {"arc", s.arc},
                       {"phase", phase_name(s.phase)}});
  out["samples"] = std::move(samples);
  return out;
}

std::string plan_to_csv(const WeldPlan& plan) {
  std::string csv = "t,j1,j2,j3,j4,j5,j6\n";
  char line[256];
  for (const PlanSample& s : plan.samples) {
    std::snprintf(line, sizeof line, "%.4f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", s.t_s, s.q[0], s.q[1], s.q[2],
                  s.q[3], s.q[4], s.q[5]);
    csv += line;
  }
  return csv;
}

}  // namespace weldtwin
