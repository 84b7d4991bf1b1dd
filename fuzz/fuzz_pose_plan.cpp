// Pose, plan and LiDAR mount JSON (the files `weldtwin plan`, `replay` and `run` take from other tools). The
// first byte picks the reader (mod 3: 0 pose, 1 plan, 2 mount; a plan is also checked against the
// tube-on-plate part). Bad input must end in InputError; a pose that is read is a rigid transform, a plan's
// times increase, a mount correction is a finite rigid transform.
#include <cmath>
#include <cstdlib>

#include "app/mount_file.hpp"
#include "app/plan_file.hpp"
#include "app/pose_file.hpp"
#include "fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace weldtwin;
  static const PartSpec part =
      PartSpec::load(std::string(WELDTWIN_SOURCE_DIR) + "/scenes/parts/tube_on_plate.yaml");
  if (size < 1) return 0;
  const std::string path = fuzz::write("in.json", data + 1, size - 1);
  return fuzz::expect_input_errors_only([&] {
    if (data[0] % 3 == 0) {
      const Iso3 T = read_pose(path);
      if (!T.matrix().allFinite() || std::abs(T.linear().determinant() - 1.0) > 1e-6) std::abort();
    } else if (data[0] % 3 == 2) {
      const MountCorrection m = read_mount_file(path);
      if (m.lidar_link.empty() || !m.correction.matrix().allFinite() ||
          std::abs(m.correction.linear().determinant() - 1.0) > 1e-6)
        std::abort();
    } else {
      const WeldPlan plan = read_plan(path);
      for (size_t k = 1; k < plan.samples.size(); ++k)
        if (!(plan.samples[k].t_s > plan.samples[k - 1].t_s)) std::abort();
      check_plan_for_part(plan, part, path);
    }
  });
}
