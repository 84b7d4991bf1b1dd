// Recorded sweeps from ROS: the first byte picks a ROS 1 bag (0 mod 3), a ROS 2 sqlite3 bag (1) or a ROS 2
// MCAP bag (2); the rest is the file. Bad input must end in InputError; a log that is read has turns within
// its samples.
#include <cstdio>
#include <cstdlib>

#include "core/cell_robot.hpp"
#include "core/cell_spec.hpp"
#include "fuzz/fuzz_file.hpp"
#include "hw/ros_bags.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace weldtwin;
  static const RobotModel robot =
      load_cell_robot(CellSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/cells/default.yaml"));
  if (size < 1) return 0;
  const int format = data[0] % 3;
  const bool ros2 = format != 0;
  // SQLite leaves a write-ahead log and its index beside a database it opened: each input starts without the
  // last one's, so an input behaves the same when it is run alone.
  for (const char* side : {"in.db3-wal", "in.db3-shm", "in.db3-journal"})
    std::remove(fuzz::scratch(side).c_str());
  const std::string path = fuzz::write(format == 0   ? "in.bag"
                                       : format == 1 ? "in.db3"
                                                     : "in.mcap",
                                       data + 1, size - 1);
  return fuzz::expect_input_errors_only([&] {
    const ScanLog log = ros2 ? read_ros2_bag(path, robot) : read_ros1_bag(path, robot);
    for (const LidarTurn& t : log.turns)
      if (static_cast<size_t>(t.first) + t.count > log.samples.size()) std::abort();
  });
}
