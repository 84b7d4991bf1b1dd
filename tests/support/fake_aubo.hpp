// A fake Aubo ARCS controller on loopback for the tests: the JSON-RPC command service and the RTDE state
// stream as docs/hardware.md describes them (the vendor's method names, parameters and result codes; SOF
// frames of MessagePack on the state service), an arm that follows a loaded path buffer in (scaled) time, and
// faults on demand. It checks the protocol as the controller would (login first, a path allocated before
// it is appended to, evaluated and valid before it is run, six finite joints per waypoint, the arm at the
// path's start) and records what it was sent.
#pragma once

#include <atomic>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/robot_model.hpp"
#include "hw/json_link.hpp"

namespace weldtwin::test {

struct FakeAuboSetting {
  std::string user = "aubo", password = "123456";
  JointVector start_q = JointVector::Zero();  ///< where the arm stands
  double time_scale = 1.0;     ///< a path runs this many times faster than its timing says (tests: faster)
  double fault_at = -1.0;      ///< at this fraction of a path: a protective stop
  double drop_rpc_at = -1.0;   ///< at this fraction: the command connection is closed (the arm keeps moving)
  double drop_rtde_at = -1.0;  ///< at this fraction: the state stream is closed
  bool mute = false;           ///< takes connections, answers nothing
  double mute_at = -1.0;       ///< at this fraction: both connections stall (open, silent) until closed
  double garbage_rpc_at = -1.0;   ///< at this fraction: the next answer is `garbage` instead
  double garbage_rtde_at = -1.0;  ///< at this fraction: the next state frame is `garbage` instead
  std::string garbage = "\x01\xff{\"R1_actual_q\":";  ///< what is sent instead (any bytes)
  std::string robot_mode = "Running";
};

class FakeAubo {
 public:
  explicit FakeAubo(FakeAuboSetting setting = {});
  ~FakeAubo();
  FakeAubo(const FakeAubo&) = delete;
  FakeAubo& operator=(const FakeAubo&) = delete;

  int rpc_port() const { return rpc_.port(); }
  int rtde_port() const { return rtde_.port(); }
  /// aubo://127.0.0.1:RPC:RTDE
  std::string spec() const;

  // What it was sent and what it did.
  std::vector<JointVector> path() const;  ///< the waypoints appended to the last path buffer
  double path_dt() const;
  double speed_fraction() const;
  std::vector<std::string> methods() const;          ///< every method called, in order
  std::vector<std::string> requests() const;         ///< every request's text, in order
  std::vector<std::string> protocol_errors() const;  ///< requests a controller would refuse
  int stops() const;
  int refused_logins() const;
  bool moving() const;
  double progress() const;  ///< of the last path run, 0..1
  JointVector q() const;

 private:
  void serve_rpc();
  void serve_rtde();
  std::string handle(const std::string& request, bool& logged_in);
  void advance(double now_s);

  FakeAuboSetting set_;
  JsonListener rpc_, rtde_;
  mutable std::mutex m_;
  std::atomic<bool> quit_{false};
  std::thread rpc_thread_, rtde_thread_;

  // State (under m_).
  JointVector q_, qd_;
  std::string safety_ = "Normal";
  std::vector<JointVector> buffer_;
  std::string buffer_name_;
  size_t buffer_size_ = 0;
  bool allocated_ = false, evaluated_ = false;
  double dt_ = 0.0, speed_ = 1.0;
  bool moving_ = false;
  double move_start_s_ = 0.0, progress_ = 0.0;
  int exec_id_ = 0, stops_ = 0, refused_logins_ = 0;
  bool drop_rpc_now_ = false, drop_rtde_now_ = false;
  bool mute_rpc_now_ = false, mute_rtde_now_ = false;        // stall the current connection
  bool garbage_rpc_now_ = false, garbage_rtde_now_ = false;  // the next message is garbage
  std::vector<std::string> methods_, requests_, errors_;
};

}  // namespace weldtwin::test
