// Writes small seed bags for fuzz_ros_bag with weldtwin's own writers (as `weldtwin scan --rosbag1/2` records
// a twin sweep): three LiDAR turns of 16 beams and joint states, as a ROS 1 bag and ROS 2 sqlite3 and MCAP
// bags, each prefixed with the harness's format byte; and the same with the arm's poses on /tf instead.
//   seed_bags OUT_DIR
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "hw/ros_bags.hpp"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  if (argc != 2) return 2;
  weldtwin::ScanLog log;
  log.joint_names = {"shoulder_joint", "upperArm_joint", "foreArm_joint",
                     "wrist1_joint",   "wrist2_joint",   "wrist3_joint"};
  for (int t = 0; t < 3; ++t) {
    log.turns.push_back({0.1 * t, static_cast<uint32_t>(16 * t), 16});
    for (int i = 0; i < 16; ++i)
      log.samples.push_back({0.1 * t + 0.1 * i / 16, static_cast<float>(0.39269908 * i),
                             static_cast<float>(0.5 + 0.01 * i), 40});
  }
  for (int k = 0; k < 4; ++k) {
    weldtwin::JointState js;
    js.t_s = 0.1 * k;
    js.q.setConstant(0.01 * k);
    log.joints.push_back(js);
  }
  const fs::path out = argv[1], tmp = out / "tmp";
  fs::create_directories(tmp);
  auto put = [&](const fs::path& from, const char* name, char format) {
    std::ifstream in(from, std::ios::binary);
    std::ofstream o(out / name, std::ios::binary);
    o << format << std::string(std::istreambuf_iterator<char>(in), {});
  };
  const weldtwin::RobotModel robot = weldtwin::load_cell_robot(
      weldtwin::CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/default.yaml"));
  for (const weldtwin::RobotModel* tf : {static_cast<const weldtwin::RobotModel*>(nullptr), &robot}) {
    const std::string name = tf ? "twin_tf" : "twin";
    weldtwin::write_ros1_bag((tmp / "seed.bag").string(), log, 1.7e9, tf);
    put(tmp / "seed.bag", (name + ".bag").c_str(), '\0');
    fs::remove_all(tmp / "ros2");
    fs::remove_all(tmp / "mcap");
    weldtwin::write_ros2_bag((tmp / "ros2").string(), log, 1.7e9, weldtwin::Ros2Storage::kSqlite3, tf);
    for (const auto& e : fs::directory_iterator(tmp / "ros2"))
      if (e.path().extension() == ".db3") put(e.path(), (name + ".db3").c_str(), '\1');
    weldtwin::write_ros2_bag((tmp / "mcap").string(), log, 1.7e9, weldtwin::Ros2Storage::kMcap, tf);
    for (const auto& e : fs::directory_iterator(tmp / "mcap"))
      if (e.path().extension() == ".mcap") put(e.path(), (name + ".mcap").c_str(), '\2');
  }
  fs::remove_all(tmp);
  return 0;
}
