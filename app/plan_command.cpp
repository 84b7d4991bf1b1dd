#include "app/plan_command.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/cell_spec.hpp"
#include "core/error.hpp"
#include "core/part_spec.hpp"
#include "perception/mesh_io.hpp"
#include "planning/weld_planner.hpp"

namespace weldtwin {

// T_base_part from a pose JSON (DESIGN.md: {"T_base_part": [[4x4 row-major]], ...}).
namespace {

constexpr double kMaxSampleGap = 1.0;  // plans are sampled at 200 Hz: samples a second apart are no plan [s]
constexpr long long kMaxSeams = 1 << 20;  // a seam index beyond any part's
constexpr size_t kMinWeldSamples = 2;     // a seam is welded over at least two samples

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

namespace {

nlohmann::json pose_json(const Iso3& T) {
  const Quat q(T.linear());
  return {T.translation().x(), T.translation().y(), T.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

}  // namespace

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
  out["T_flange_tcp"] = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    out["T_flange_tcp"].push_back({plan.T_flange_tcp.matrix()(r, 0), plan.T_flange_tcp.matrix()(r, 1),
                                   plan.T_flange_tcp.matrix()(r, 2), plan.T_flange_tcp.matrix()(r, 3)});
  for (const PlannedSeam& s : plan.seams) {
    nlohmann::json rolls = nlohmann::json::array();
    for (double r : s.roll_per_piece_rad) rolls.push_back(r * 180.0 / kPi);
    out["seams"].push_back({{"name", s.name},
                            {"start_base", {s.start_base.x(), s.start_base.y(), s.start_base.z()}},
                            {"end_base", {s.end_base.x(), s.end_base.y(), s.end_base.z()}},
                            {"length_m", s.length_m},
                            {"speed_m_s", s.speed_m_s},
                            {"pieces", s.pieces},
                            {"torch_roll_deg", rolls}});
  }
  nlohmann::json samples = nlohmann::json::array();
  for (const PlanSample& s : plan.samples)
    samples.push_back({{"t", s.t_s},
                       {"q", {s.q[0], s.q[1], s.q[2], s.q[3], s.q[4], s.q[5]}},
                       {"tcp", pose_json(s.T_base_tcp)},
                       {"seam", s.seam},
                       {"arc", s.arc},
                       {"phase", phase_name(s.phase)}});
  out["samples"] = std::move(samples);
  return out;
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

int run_plan(const PlanCommand& cmd) {
  const CellSpec cell = CellSpec::load(cell_or_default(cmd.cell));
  const RobotModel robot = RobotModel::load(cell.robot_urdf);
  const PartSpec part = PartSpec::load(cmd.part);
  const Iso3 T_base_part = read_pose(cmd.pose);
  // A part rests on the table: a pose that puts it into the table top, or far above it, is no pose of it.
  {
    constexpr double kRestTolerance = 0.02;  // a mount off by some millimetres still plans [m]
    double lowest = 1e300;
    for (const Vec3& v : load_mesh(part.mesh_path).vertices) lowest = std::min(lowest, (T_base_part * v).z());
    const double off = lowest - cell.table.top_z_m;
    if (std::abs(off) > kRestTolerance) {
      char buf[200];
      std::snprintf(buf, sizeof buf, "the pose puts the part's lowest point %.0f mm %s the table top of %s",
                    1e3 * std::abs(off), off < 0 ? "below" : "above", cell_or_default(cmd.cell).c_str());
      throw input_error(cmd.pose, buf);
    }
  }
  const PlanSetting setting;
  const WeldPlan plan = plan_welds(part, T_base_part, robot, setting);

  nlohmann::json out = plan_to_json(plan, part, robot, setting);
  // This plan is checked against the joint limits only: the cell's table, clamps and part are checked when
  // the plan is replayed (weldtwin replay, weldtwin run).
  out["collisions_checked"] = false;
  std::ofstream(cmd.out) << out.dump() << '\n';
  if (!cmd.csv.empty()) {
    std::ofstream csv(cmd.csv);
    csv << "t,j1,j2,j3,j4,j5,j6\n";
    char line[256];
    for (const PlanSample& s : plan.samples) {
      std::snprintf(line, sizeof line, "%.4f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", s.t_s, s.q[0], s.q[1], s.q[2],
                    s.q[3], s.q[4], s.q[5]);
      csv << line;
    }
  }
  if (!cmd.quiet) {
    std::fprintf(stderr, "plan: %s, %zu seams, %.1f s, %zu samples at %.0f Hz -> %s\n", part.name.c_str(),
                 plan.seams.size(), plan.duration_s(), plan.samples.size(), setting.sample_hz,
                 cmd.out.c_str());
    for (const auto& n : plan.notes) std::fprintf(stderr, "plan: note: %s\n", n.c_str());
    std::fprintf(stderr,
                 "plan: note: collisions not checked (joint limits only): replay it in the cell "
                 "(weldtwin replay %s) before it goes to a robot\n",
                 cmd.out.c_str());
  }
  if (!plan.ok()) {
    std::fprintf(stderr, "weldtwin: %s: %s\n", cmd.part.c_str(), plan.problems.front().c_str());
    return 3;
  }
  return 0;
}

}  // namespace weldtwin
