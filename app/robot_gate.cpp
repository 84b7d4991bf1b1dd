#include "app/robot_gate.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/plan_file.hpp"
#include "core/error.hpp"

namespace weldtwin {

std::string sha256_hex(const std::string& bytes) {
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1 ||
      EVP_DigestUpdate(ctx.get(), bytes.data(), bytes.size()) != 1 ||
      EVP_DigestFinal_ex(ctx.get(), digest, &n) != 1)
    throw std::runtime_error("SHA-256 failed (OpenSSL)");
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < n; ++i) {
    out += hex[digest[i] >> 4];
    out += hex[digest[i] & 0xF];
  }
  return out;
}

namespace {
std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path, "cannot be read");
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
}  // namespace

std::string sha256_of_file(const std::string& path) {
  return sha256_hex(read_file(path));
}

JointTrajectory plan_trajectory(const WeldPlan& plan, const std::string& source) {
  JointTrajectory t;
  if (plan.samples.size() < 2) throw GateRefused(source + ": the plan has fewer than two samples");
  t.dt_s = plan.samples[1].t_s - plan.samples[0].t_s;
  for (size_t i = 0; i < plan.samples.size(); ++i) {
    const double expected = plan.samples[0].t_s + t.dt_s * static_cast<double>(i);
    if (std::abs(plan.samples[i].t_s - expected) > 1e-6)
      throw GateRefused(source + ": sample " + std::to_string(i) + " is off the plan's even time step");
    t.q.push_back(plan.samples[i].q);
  }
  return t;
}

GatedPlan open_gate(const std::string& dir) {
  const std::string report_path = dir + "/report.json", plan_path = dir + "/plan.json";
  std::string report_text;
  try {
    report_text = read_file(report_path);
  } catch (const InputError&) {
    throw GateRefused(report_path + ": no report: the plan was not replayed");
  }
  const nlohmann::json report = nlohmann::json::parse(report_text, nullptr, false);
  if (report.is_discarded() || !report.is_object()) throw GateRefused(report_path + ": not a report");
  if (report.value("verdict", "") != "PASS") {
    std::string why = "the run did not pass";
    if (report.contains("reasons") && report["reasons"].is_array() && !report["reasons"].empty())
      why += " (" + report["reasons"][0].get<std::string>() + ")";
    throw GateRefused(why);
  }
  if (!report.contains("replay") || !report["replay"].value("passed", false))
    throw GateRefused(report_path + ": the plan's replay in the twin did not pass");
  const std::string named = report.contains("plan") ? report["plan"].value("sha256", "") : "";
  if (named.empty()) throw GateRefused(report_path + ": names no plan hash");
  GatedPlan g;
  try {
    g.sha256 = sha256_of_file(plan_path);
  } catch (const InputError&) {
    throw GateRefused(plan_path + ": missing");
  }
  if (g.sha256 != named)
    throw GateRefused(plan_path + ": changed since its replay (SHA-256 " + g.sha256.substr(0, 12) +
                      ", the passed report names " + named.substr(0, 12) + ")");
  g.plan = read_plan(plan_path);
  g.trajectory = plan_trajectory(g.plan, plan_path);
  return g;
}

}  // namespace weldtwin
