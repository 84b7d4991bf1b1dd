// The robot drivers. The Aubo driver against a fake ARCS controller on loopback (tests/support/fake_aubo):
// the trajectory the controller receives equals the one sent, sample for sample, at the plan's step and the
// speed override; a refused login, an unreachable or mute controller, an arm not ready or not at the start
// are refused before anything moves; a controller fault, a dropped command connection, a dropped state
// stream and a stop request mid-run each end in one clear error with a stop sent and the arm standing.
// The sim driver runs a trajectory in the twin and fails one that drives the arm into the table.
#include "hw/robot_driver.hpp"

#include <gtest/gtest.h>

#include <atomic>

#include "core/cell_robot.hpp"
#include "core/error.hpp"
#include "hw/aubo_protocol.hpp"
#include "hw/json_link.hpp"
#include "perception/mesh_io.hpp"
#include "planning/weld_planner.hpp"
#include "sim/collision_check.hpp"
#include "tests/support/fake_aubo.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

const RobotModel& robot() {
  static const RobotModel r = load_cell_robot(CellSpec::load(test::repo("scenes/cells/default.yaml")));
  return r;
}

const JointVector kHome = PlanSetting().home;

// A 2 s move from home at 200 Hz, smooth (cosine) in every joint.
JointTrajectory a_move(
    double seconds = 2.0,
    const JointVector& delta = (JointVector() << 0.4, -0.2, 0.3, 0.25, -0.35, 0.5).finished()) {
  JointTrajectory t;
  const int n = static_cast<int>(seconds / t.dt_s);
  for (int i = 0; i <= n; ++i) t.q.push_back(kHome + delta * 0.5 * (1 - std::cos(kPi * i / n)));
  return t;
}

test::FakeAuboSetting fake_at_home(double time_scale = 4.0) {
  test::FakeAuboSetting s;
  s.start_q = kHome;
  s.time_scale = time_scale;
  return s;
}

RobotDriverSetting quick(double timeout_s = 1.0) {
  RobotDriverSetting s;
  s.timeout_s = timeout_s;
  return s;
}

// The MessagePack encoding of `j` (an RTDE payload).
std::string msgpack(const nlohmann::json& j) {
  const std::vector<std::uint8_t> b = nlohmann::json::to_msgpack(j);
  return std::string(b.begin(), b.end());
}

std::unique_ptr<RobotDriver> driver_for(const test::FakeAubo& fake, const RobotDriverSetting& s = quick()) {
  return make_robot_driver(fake.spec(), robot(), SimRobotInputs(), s);
}

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// Runs `fn`, which must throw E; returns its message.
template <class E, class F>
std::string error_of(F fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error thrown";
  return "";
}

TEST(JsonFramer, SplitsObjectsWhateverTheChunks) {
  const std::string stream = R"({"a":"}{\"","b":[1,{"c":2}]}  {"d":"\\"}
{"e":[]})";
  for (size_t chunk : {1, 3, 7, 1000}) {
    JsonFramer f;
    std::vector<std::string> got;
    for (size_t i = 0; i < stream.size(); i += chunk) {
      f.feed(stream.data() + i, std::min(chunk, stream.size() - i));
      std::string o;
      while (f.next(o)) got.push_back(o);
    }
    ASSERT_EQ(got.size(), 3u) << "chunk " << chunk;
    EXPECT_EQ(got[0], R"({"a":"}{\"","b":[1,{"c":2}]})");
    EXPECT_EQ(got[1], R"({"d":"\\"})");
    EXPECT_EQ(got[2], R"({"e":[]})");
  }
}

TEST(AuboDriver, TheControllerReceivesTheTrajectorySampleForSample) {
  test::FakeAubo fake(fake_at_home());
  RobotDriverSetting s = quick();
  s.speed_fraction = 0.5;
  auto driver = driver_for(fake, s);
  driver->connect();
  EXPECT_LT((driver->joint_positions() - kHome).norm(), 1e-12);
  const JointTrajectory t = a_move();
  std::vector<double> host_times;
  const ExecutionLog log =
      driver->execute(t, [&](double host_s, const JointState&) { host_times.push_back(host_s); });

  const std::vector<JointVector> got = fake.path();
  ASSERT_EQ(got.size(), t.q.size());
  for (size_t i = 0; i < got.size(); ++i)
    for (int j = 0; j < 6; ++j) ASSERT_EQ(got[i][j], t.q[i][j]) << "sample " << i << " joint " << j;
  EXPECT_EQ(fake.path_dt(), t.dt_s);
  EXPECT_EQ(fake.speed_fraction(), 0.5);
  EXPECT_TRUE(fake.protocol_errors().empty()) << fake.protocol_errors().front();
  EXPECT_EQ(log.samples_sent, t.q.size());
  EXPECT_EQ(fake.stops(), 0);
  EXPECT_FALSE(fake.moving());
  EXPECT_LT((fake.q() - t.q.back()).norm(), 1e-12);
  // The joint log: what the arm reported, in time order, along the path, ending at its end. At half speed and
  // a 4x fast fake, the 2 s path takes 1 s.
  ASSERT_GT(log.joints.size(), 100u);
  for (size_t k = 1; k < log.joints.size(); ++k) {
    EXPECT_GT(log.joints[k].t_s, log.joints[k - 1].t_s);
    EXPECT_GE(log.joints[k].q[0], log.joints[k - 1].q[0] - 1e-12);  // joint 1 only rises along this move
  }
  EXPECT_LT((log.joints.back().q - t.q.back()).norm(), 1e-9);
  EXPECT_GT(log.wall_s, 0.95);  // at full speed it would take 0.5 s
  EXPECT_LT(log.wall_s, 3.0);
  EXPECT_EQ(host_times.size(), log.joints.size());
}

TEST(AuboDriver, ARefusedLoginSendsNothing) {
  test::FakeAubo fake(fake_at_home());
  RobotDriverSetting s = quick();
  s.password = "wrong";
  auto driver = driver_for(fake, s);
  const std::string e = error_of<InputError>([&] { driver->connect(); });
  EXPECT_TRUE(contains(e, "login refused")) << e;
  EXPECT_TRUE(contains(e, fake.spec().substr(7))) << e;  // names the controller
  EXPECT_EQ(fake.refused_logins(), 1);
  EXPECT_EQ(fake.methods(), std::vector<std::string>{"__login__"});
  EXPECT_TRUE(fake.path().empty());
}

TEST(AuboDriver, UnreachableMuteOrUnreadyControllersAreRefusedClearly) {
  {  // nobody listening
    int port = 0;
    { port = JsonListener().port(); }  // a port just freed
    auto driver = make_robot_driver("aubo://127.0.0.1:" + std::to_string(port), robot(), {}, quick());
    const std::string e = error_of<InputError>([&] { driver->connect(); });
    EXPECT_TRUE(contains(e, "cannot reach")) << e;
  }
  {  // takes the connection, never answers
    test::FakeAuboSetting fs = fake_at_home();
    fs.mute = true;
    test::FakeAubo fake(fs);
    auto driver = driver_for(fake, quick(0.3));
    const double t0 = host_seconds();
    const std::string e = error_of<InputError>([&] { driver->connect(); });
    EXPECT_TRUE(contains(e, "no answer to __login__")) << e;
    EXPECT_LT(host_seconds() - t0, 2.0);
  }
  {  // powered off
    test::FakeAuboSetting fs = fake_at_home();
    fs.robot_mode = "PowerOff";
    test::FakeAubo fake(fs);
    auto driver = driver_for(fake);
    const std::string e = error_of<RobotError>([&] { driver->connect(); });
    EXPECT_TRUE(contains(e, "not ready (robot mode PowerOff)")) << e;
  }
  EXPECT_THROW(make_robot_driver("aubo://", robot(), {}, quick()), InputError);
  EXPECT_THROW(make_robot_driver("aubo://host:port", robot(), {}, quick()), InputError);
  EXPECT_THROW(make_robot_driver("ur://host", robot(), {}, quick()), InputError);
  RobotDriverSetting fast = quick();
  fast.speed_fraction = 1.5;
  EXPECT_THROW(make_robot_driver("aubo://host", robot(), {}, fast), InputError);
}

TEST(AuboDriver, NothingIsSentUnlessTheArmStandsAtTheStart) {
  test::FakeAuboSetting fs = fake_at_home();
  fs.start_q[1] += 0.1;
  test::FakeAubo fake(fs);
  auto driver = driver_for(fake);
  driver->connect();
  const std::string e = error_of<RobotError>([&] { driver->execute(a_move()); });
  EXPECT_TRUE(contains(e, "0.100 rad from the trajectory's start; nothing was sent")) << e;
  EXPECT_TRUE(fake.path().empty());
  EXPECT_FALSE(fake.moving());
}

// Runs a_move() against a fake set up by `tweak`; returns the error, having checked the arm was stopped.
std::string failing_run(void (*tweak)(test::FakeAuboSetting&), const std::atomic<bool>* stop = nullptr,
                        const std::function<void(double, const JointState&)>& on_state = {}) {
  test::FakeAuboSetting fs = fake_at_home(2.0);
  tweak(fs);
  test::FakeAubo fake(fs);
  RobotDriverSetting s = quick();
  s.stop_request = stop;
  auto driver = driver_for(fake, s);
  driver->connect();
  const std::string e = error_of<RobotError>([&] { driver->execute(a_move(), on_state); });
  EXPECT_GE(fake.stops(), 1) << "no stop sent: " << e;
  EXPECT_FALSE(fake.moving()) << e;
  EXPECT_LT(fake.progress(), 0.9) << e;
  EXPECT_TRUE(fake.protocol_errors().empty()) << fake.protocol_errors().front();
  return e;
}

TEST(AuboDriver, AControllerFaultMidRunStopsWithAClearError) {
  const std::string e = failing_run([](test::FakeAuboSetting& s) { s.fault_at = 0.5; });
  EXPECT_TRUE(contains(e, "controller fault: safety mode ProtectiveStop")) << e;
  EXPECT_TRUE(contains(e, "stop sent, the arm halted")) << e;
}

TEST(AuboDriver, ADroppedCommandConnectionReconnectsToStopTheArm) {
  const std::string e = failing_run([](test::FakeAuboSetting& s) { s.drop_rpc_at = 0.3; });
  EXPECT_TRUE(contains(e, "the command connection failed")) << e;
  EXPECT_TRUE(contains(e, "stop sent")) << e;
}

TEST(AuboDriver, ADroppedStateStreamStopsTheArm) {
  const std::string e = failing_run([](test::FakeAuboSetting& s) { s.drop_rtde_at = 0.3; });
  EXPECT_TRUE(contains(e, "the state stream dropped")) << e;
  EXPECT_TRUE(contains(e, "stop sent, the controller reports no motion")) << e;
}

TEST(AuboDriver, AStopRequestHaltsTheArm) {
  std::atomic<bool> stop{false};
  const std::string e = failing_run([](test::FakeAuboSetting&) {}, &stop,
                                    [&](double, const JointState& js) {
                                      if (js.t_s > 0.3) stop = true;
                                    });
  EXPECT_TRUE(contains(e, "stopped on request (SIGINT); stop sent, the arm halted")) << e;
}

TEST(AuboDriver, GarbageOnTheStateStreamStopsTheArmAndKeepsTheRecord) {
  // A state frame whose mode is a number: read before as an uncaught JSON type error, with the arm moving.
  test::FakeAuboSetting fs = fake_at_home(2.0);
  fs.garbage_rtde_at = 0.3;
  fs.garbage = msgpack({0, {0, 0, 1.5, 0, 1.5, 0}, {0, 0, 0, 0, 0, 0}, 7, "Normal"});
  test::FakeAubo fake(fs);
  auto driver = driver_for(fake);
  driver->connect();
  try {
    driver->execute(a_move());
    ADD_FAILURE() << "no error thrown";
  } catch (const RobotError& e) {
    EXPECT_TRUE(contains(e.what(), "malformed state frame: R1_robot_mode is not a name")) << e.what();
    EXPECT_TRUE(contains(e.what(), "stop sent")) << e.what();
    // The record keeps what was seen up to the fault: states from the start to about 30 % of the path.
    ASSERT_GT(e.log().joints.size(), 10u);
    EXPECT_GT(e.log().joints.back().t_s, 0.2);
    EXPECT_EQ(e.log().exchanges.back(), "movePathBuffer");
  }
  EXPECT_GE(fake.stops(), 1);
  EXPECT_FALSE(fake.moving());
  EXPECT_LT(fake.progress(), 0.9);
}

TEST(AuboDriver, AControllerThatFallsSilentMidRunIsStoppedOverANewConnection) {
  // Both connections stall at 20 % of a 2 s path: the silence is noticed after the timeout (0.25 s), the stop
  // on the stalled command connection times out, and goes over a new one; the halt is confirmed by the
  // controller's motion id, the state stream being silent.
  test::FakeAuboSetting fs = fake_at_home(1.0);
  fs.mute_at = 0.2;
  test::FakeAubo fake(fs);
  auto driver = driver_for(fake, quick(0.25));
  driver->connect();
  const std::string e = error_of<RobotError>([&] { driver->execute(a_move()); });
  // Whichever connection's silence is noticed first (the state stream's, or the motion id's poll).
  EXPECT_TRUE(contains(e, "the state stream is silent") || contains(e, "no answer to")) << e;
  EXPECT_TRUE(contains(e, "stop sent, the controller reports no motion")) << e;
  EXPECT_GE(fake.stops(), 1);
  EXPECT_FALSE(fake.moving());
  EXPECT_LT(fake.progress(), 0.8);
}

TEST(SofFramer, CutsFramesWhateverTheChunksAndSkipsWhatIsNotAFrame) {
  // Two frames (one empty, one of 300 bytes: a length above 255), garbage between them, a frame cut short.
  const std::string big(300, 'x');
  const std::string stream = sof_frame("ab", 1) + "\x01garbage SO" + sof_frame("", 7) + sof_frame(big, 1) +
                             sof_frame("cut short", 1).substr(0, 9);
  ASSERT_EQ(sof_frame("ab", 1), std::string("SOF\x01\x00\x02"
                                            "ab",
                                            8));  // 'S' 'O' 'F', version, big-endian length
  for (size_t chunk : {1, 2, 5, 1000}) {
    SofFramer f;
    std::vector<std::string> got;
    std::vector<int> versions;
    for (size_t i = 0; i < stream.size(); i += chunk) {
      f.feed(stream.data() + i, std::min(chunk, stream.size() - i));
      std::string p;
      unsigned char v = 0;
      while (f.next(p, &v)) got.push_back(p), versions.push_back(v);
    }
    ASSERT_EQ(got.size(), 3u) << "chunk " << chunk;
    EXPECT_EQ(got[0], "ab");
    EXPECT_EQ(got[1], "");
    EXPECT_EQ(got[2], big);
    EXPECT_EQ(versions, (std::vector<int>{1, 7, 1}));
    EXPECT_EQ(f.pending(), 9u) << "the cut frame waits for the rest";
  }
  SofFramer f;
  const std::string noise(100000, 'z');
  f.feed(noise.data(), noise.size());
  std::string p;
  EXPECT_FALSE(f.next(p));
  EXPECT_LE(f.pending(), 2u) << "bytes that cannot begin a frame are not kept";
  EXPECT_THROW(sof_frame(std::string(65536, 'x'), 1), std::length_error);
}

TEST(AuboProtocol, MalformedMessagesAreLinkErrorsAndRefusalsAreRefused) {
  aubo::StateFrame f;
  EXPECT_TRUE(
      aubo::parse_state_frame(msgpack({0, {1, 2, 3, 4, 5, 6}, {0, 0, 0, 0, 0, 0}, "Running", "Normal"}), f));
  EXPECT_EQ(f.q[5], 6.0);
  EXPECT_EQ(f.robot_mode, "Running");
  EXPECT_FALSE(aubo::parse_state_frame(msgpack({100, 0}), f));  // the subscription's answer
  for (const std::string& bad :
       {msgpack({0, {1, 2, 3, 4, 5}, {0, 0, 0, 0, 0, 0}, "Running", "Normal"}),
        msgpack({0, {1, 2, 3, 4, 5, "6"}, {0, 0, 0, 0, 0, 0}, "Running", "Normal"}),
        msgpack({0, {1, 2, 3, 4, 5, 6}, {0, 0, 0, 0, 0, 0}, nlohmann::json::array(), "Normal"}),
        msgpack({0, {1, 2, 3, 4, 5, 6}, {0, 0, 0, 0, 0, 0}, "Running"}),  // a segment missing
        msgpack({100, -1}),                                               // the subscription refused
        msgpack({{"R1_actual_q", {1, 2, 3, 4, 5, 6}}}),                   // an object, not the frame
        std::string("\x95\x00"), std::string("{\"a\":1}"), std::string()})
    EXPECT_THROW(aubo::parse_state_frame(bad, f), LinkError) << nlohmann::json(bad.substr(0, 20)).dump();
  EXPECT_EQ(f.q[5], 6.0) << "a malformed frame must leave the last good one";
  // The subscription, decoded: the vendor's RTDE index and recipe members (and its spelling of "chanel").
  const nlohmann::json sub = nlohmann::json::from_msgpack(aubo::subscription(0, 200.0));
  EXPECT_EQ(sub, nlohmann::json::parse(R"([100, {"chanel": 0, "frequency": 200.0, "segments": ["R1_actual_q",
      "R1_actual_qd", "R1_robot_mode", "R1_safety_mode"], "to_server": false, "trigger": 0}])"));
  EXPECT_FALSE(aubo::parse_reply(R"({"jsonrpc":"2.0","result":5,"id":2})", 1, "m"));  // another request's
  EXPECT_EQ(aubo::parse_reply(R"({"jsonrpc":"2.0","result":5,"id":1})", 1, "m")->get<int>(), 5);
  EXPECT_THROW(aubo::parse_reply(R"({"error":{"code":-1,"message":7},"id":1})", 1, "m"), aubo::Refused);
  EXPECT_THROW(aubo::parse_reply("{\"id\":1", 1, "m"), LinkError);
  // Result codes: 0 is success, any other code a refusal naming it.
  EXPECT_NO_THROW(aubo::expect_success(0, "m"));
  EXPECT_TRUE(contains(error_of<aubo::Refused>([] { aubo::expect_success(-5, "pathBufferFree"); }),
                       "pathBufferFree refused: error code -5"));
  EXPECT_THROW(aubo::expect_success("0", "m"), LinkError);
}

TEST(AuboDriver, ADryRunListsTheRequestsWithoutConnecting) {
  auto driver = make_robot_driver("aubo://192.0.2.1", robot(), {}, quick());  // TEST-NET: nothing there
  const JointTrajectory t = a_move();
  const std::string text = driver->dry_run(t);
  EXPECT_TRUE(contains(text, "\"method\": \"rob1.MotionControl.movePathBuffer\"")) << text.substr(0, 400);
  EXPECT_TRUE(contains(text, "\"method\": \"__login__\"")) << text.substr(0, 400);
  EXPECT_TRUE(contains(text, "\"samples\": " + std::to_string(t.q.size())));
  EXPECT_FALSE(contains(text, "123456"));  // no password in a file
}

TEST(SimDriver, RunsATrajectoryInTheTwinAndFailsOneIntoTheTable) {
  const test::Cell cell;
  const Mesh mesh = load_mesh(cell.part.mesh_path);
  SimRobotInputs sim{cell.world.get(), &cell.part, &mesh, cell.layout.T_base_part};
  auto driver = make_robot_driver("sim", cell.robot, sim, quick());
  // A move clear of the cell (wrist 2 turned the other way: the default move swings the 45 deg neck into a
  // clamp arm), as the cell's checker says at every sample.
  const JointTrajectory t = a_move(2.0, (JointVector() << 0.4, -0.2, 0.3, 0.25, 0.35, 0.5).finished());
  const CollisionChecker checker(*cell.world);
  for (size_t i = 0; i < t.q.size(); ++i) ASSERT_EQ(checker(t.q[i]), "") << "sample " << i;
  const ExecutionLog log = driver->execute(t);
  ASSERT_EQ(log.joints.size(), t.q.size());
  for (size_t i = 0; i < t.q.size(); i += 20)
    EXPECT_LT((log.joints[i].q - t.q[i]).cwiseAbs().maxCoeff(), 2e-3);
  EXPECT_LT((driver->joint_positions() - t.q.back()).cwiseAbs().maxCoeff(), 2e-3);

  // From where it stands, down into the table (the shoulder forward until the checker says so).
  JointVector end = t.q.back();
  while (checker(end).empty() && end[1] < 2.5) end[1] += 0.05;
  ASSERT_FALSE(checker(end).empty());
  JointTrajectory down;
  for (int i = 0; i <= 400; ++i)
    down.q.push_back(t.q.back() + (end - t.q.back()) * (0.5 * (1 - std::cos(kPi * i / 400))));
  const std::string e = error_of<RobotError>([&] { driver->execute(down); });
  EXPECT_TRUE(contains(e, "the twin's arm failed")) << e;
}

}  // namespace
}  // namespace weldtwin
