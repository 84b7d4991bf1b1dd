// The Aubo driver and the fake controller against the vendor's own JSON-RPC examples (the request/response
// pairs of the ARCS SDK's headers, in the real-data folder; skipped, saying so, without it):
//   - every request the driver sends in a whole run has the method name of a vendor example and its
//     positional parameters in the same form (the same count; numbers, strings and booleans where the
//     example has them; joint vectors of six), but for the login, which no public example shows;
//   - the fake controller answers the vendor's requests, sent verbatim, with results of the vendor's form
//     (and the vendor's values where they do not depend on the arm: the robot's name, the modes, "no such
//     buffer", "no motion", "not valid yet", success codes).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "hw/json_link.hpp"
#include "hw/robot_driver.hpp"
#include "tests/real_data.hpp"
#include "tests/support/fake_aubo.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using nlohmann::json;

struct Example {
  json request, response;
};

// The vendor's examples by method name (the first of each).
std::map<std::string, Example> vendor_examples(const std::string& path) {
  std::map<std::string, Example> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    const json row = json::parse(line);
    // Every request parses; one response of the headers does not (a full-width comma in its numbers), and
    // is left out, as a null.
    Example e{json::parse(row.at("request").get<std::string>()),
              json::parse(row.at("response").get<std::string>(), nullptr, false)};
    if (e.response.is_discarded()) e.response = nullptr;
    out.emplace(e.request.at("method").get<std::string>(), e);
  }
  return out;
}

// Whether `ours` has the form of the vendor's `theirs`: the same JSON type (any number for a number); arrays
// of numbers of the same length (joint vectors, limits); arrays of arrays of any length, every element of the
// form of the vendor's first (a list of waypoints); objects with the same keys.
bool same_form(const json& ours, const json& theirs, std::string& why, const std::string& at) {
  auto differ = [&](const std::string& what) {
    why = at + ": " + what + " (ours " + ours.dump().substr(0, 60) + ", the vendor's " +
          theirs.dump().substr(0, 60) + ")";
    return false;
  };
  if (theirs.is_number()) return ours.is_number() || differ("not a number");
  if (theirs.type() != ours.type()) return differ("another type");
  if (theirs.is_object()) {
    if (ours.size() != theirs.size()) return differ("other members");
    for (const auto& [k, v] : theirs.items())
      if (!ours.contains(k) || !same_form(ours[k], v, why, at + "." + k))
        return why.empty() ? differ(k) : false;
    return true;
  }
  if (!theirs.is_array()) return true;
  const bool list_of_lists = !theirs.empty() && theirs[0].is_array();
  if (!list_of_lists) {
    if (ours.size() != theirs.size()) return differ("another length");
    for (size_t i = 0; i < theirs.size(); ++i)
      if (!same_form(ours[i], theirs[i], why, at + "[" + std::to_string(i) + "]")) return false;
    return true;
  }
  if (ours.empty()) return differ("empty");
  for (size_t i = 0; i < ours.size(); ++i)
    if (!same_form(ours[i], theirs[0], why, at + "[" + std::to_string(i) + "]")) return false;
  return true;
}

const RobotModel& robot() {
  static const RobotModel r = load_cell_robot(CellSpec::load(test::repo("scenes/cells/default.yaml")));
  return r;
}

const JointVector kHome = (JointVector() << 0, 0, kPi / 2, 0, kPi / 2, 0).finished();

class AuboVendorExamples : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = test::real_data("aubo_arcs/jsonrpc_examples.jsonl");
    if (!std::filesystem::exists(path_))
      GTEST_SKIP() << "skipped: ../shared/real not found (" << path_ << ")";
    examples_ = vendor_examples(path_);
    ASSERT_GT(examples_.size(), 100u) << path_;
  }
  std::string path_;
  std::map<std::string, Example> examples_;
};

TEST_F(AuboVendorExamples, EveryRequestOfARunHasTheFormOfTheVendorsExample) {
  test::FakeAuboSetting fs;
  fs.start_q = kHome;
  fs.time_scale = 4.0;
  test::FakeAubo fake(fs);
  RobotDriverSetting s;
  s.timeout_s = 1.0;
  auto driver = make_robot_driver(fake.spec(), robot(), SimRobotInputs(), s);
  driver->connect();
  JointTrajectory t;
  for (int i = 0; i <= 300; ++i) t.q.push_back(kHome + JointVector::Constant(0.2 * i / 300.0));
  driver->execute(t);
  ASSERT_TRUE(fake.protocol_errors().empty()) << fake.protocol_errors().front();

  std::map<std::string, int> sent;
  for (const std::string& text : fake.requests()) {
    const json r = json::parse(text);
    const std::string method = r.at("method");
    ++sent[method];
    EXPECT_EQ(r.at("jsonrpc"), "2.0") << text.substr(0, 80);
    EXPECT_TRUE(r.at("id").is_number_integer()) << text.substr(0, 80);
    EXPECT_EQ(text, r.dump()) << "compact JSON, nothing around it";
    if (method == "__login__") continue;  // no public example shows the login's request
    const auto e = examples_.find(method);
    if (e == examples_.end()) {
      ADD_FAILURE() << "the driver sends " << method << ", which no vendor example has";
      continue;
    }
    std::string why;
    EXPECT_TRUE(same_form(r.at("params"), e->second.request.at("params"), why, method)) << why;
  }
  // The run used the whole exchange: what loads, checks, runs and watches a path.
  for (const char* m :
       {"getRobotNames", "rob1.RobotState.getRobotModeType", "rob1.RobotState.getSafetyModeType",
        "rob1.MotionControl.pathBufferFree", "rob1.MotionControl.setSpeedFraction",
        "rob1.MotionControl.pathBufferAlloc", "rob1.MotionControl.pathBufferAppend",
        "rob1.MotionControl.pathBufferEval", "rob1.MotionControl.pathBufferValid",
        "rob1.MotionControl.movePathBuffer", "rob1.MotionControl.getExecId"})
    EXPECT_GT(sent[m], 0) << m << " was not sent";
  EXPECT_EQ(sent["rob1.MotionControl.pathBufferAppend"], 2) << "301 waypoints, 200 a call";
}

TEST_F(AuboVendorExamples, TheFakeControllerAnswersTheVendorsRequestsAsTheVendorDocuments) {
  test::FakeAuboSetting fs;
  fs.start_q = kHome;
  test::FakeAubo fake(fs);
  JsonLink link = JsonLink::connect("127.0.0.1", fake.rpc_port(), 1.0);
  auto ask = [&](const json& request) {
    link.send(request.dump());
    const std::optional<std::string> answer = link.receive(1.0);
    EXPECT_TRUE(answer) << "no answer to " << request.dump();
    return answer ? json::parse(*answer) : json();
  };
  ASSERT_EQ(ask(json::parse(R"({"jsonrpc":"2.0","method":"__login__","params":["aubo","123456"],"id":0})"))
                .value("result", json()),
            0);
  // In an order where the vendor's values hold: nothing allocated or moving yet, then a buffer filled,
  // evaluated, and a stop.
  struct Check {
    const char* method;
    bool same_value;  // false: the value depends on the arm (its joints)
  };
  for (const Check& c :
       {Check{"getRobotNames", true}, Check{"rob1.RobotState.getRobotModeType", true},
        Check{"rob1.RobotState.getSafetyModeType", true}, Check{"rob1.RobotState.getJointPositions", false},
        Check{"rob1.MotionControl.getExecId", true}, Check{"rob1.MotionControl.pathBufferFree", true},
        Check{"rob1.MotionControl.pathBufferValid", true}, Check{"rob1.MotionControl.setSpeedFraction", true},
        Check{"rob1.MotionControl.pathBufferAlloc", true}, Check{"rob1.MotionControl.pathBufferAppend", true},
        Check{"rob1.MotionControl.pathBufferEval", true}, Check{"rob1.MotionControl.stopJoint", true}}) {
    const auto e = examples_.find(c.method);
    ASSERT_NE(e, examples_.end()) << c.method;
    const json answer = ask(e->second.request);
    ASSERT_TRUE(answer.contains("result")) << c.method << ": " << answer.dump();
    EXPECT_EQ(answer.at("id"), e->second.request.at("id"));
    const json& vendor = e->second.response.at("result");
    std::string why;
    EXPECT_TRUE(same_form(answer["result"], vendor, why, c.method)) << why;
    if (c.same_value) {
      EXPECT_EQ(answer["result"], vendor) << c.method;
    }
  }
  EXPECT_TRUE(fake.protocol_errors().empty()) << fake.protocol_errors().front();
}

}  // namespace
}  // namespace weldtwin
