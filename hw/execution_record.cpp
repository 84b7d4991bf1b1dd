#include "hw/execution_record.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace weldtwin {

void write_execution_record(const std::string& path, const ExecutionRecord& r) {
  nlohmann::json j;
  j["robot"] = r.robot;
  j["plan_sha256"] = r.plan_sha256;
  j["speed_fraction"] = r.speed_fraction;
  j["samples_sent"] = r.log.samples_sent;
  j["wall_s"] = r.log.wall_s;
  j["outcome"] = r.outcome;
  j["exchanges"] = r.log.exchanges;
  nlohmann::json t = nlohmann::json::array(), q = nlohmann::json::array();
  for (const JointState& s : r.log.joints) {
    t.push_back(s.t_s);
    q.push_back(std::vector<double>(s.q.data(), s.q.data() + s.q.size()));
  }
  j["joints"] = {{"t_s", t}, {"q_rad", q}};
  std::ofstream out(path);
  out << j.dump() << '\n';
  if (!out.flush()) throw std::runtime_error(path + ": cannot write the execution record");
}

}  // namespace weldtwin
