#include "sim/twin_calibration.hpp"

#include <utility>

#include "sim/cell_layout.hpp"
#include "sim/lidar_model.hpp"
#include "sim/mujoco_world.hpp"

namespace weldtwin {

CalibrationCell::CalibrationCell(CellSpec cell_spec, const RobotModel& robot)
    : cell(std::move(cell_spec)),
      box(PartSpec::load(cell.part_spec)),
      box_mesh(load_mesh(box.mesh_path)),
      program(SweepProgram::load(cell.sweep_program, robot)) {}

MountCalibration calibrate_in_twin(const CalibrationCell& cal, const RobotModel& real_robot,
                                   const RobotModel& nominal_robot, uint64_t lidar_seed,
                                   const SweepOptions& options) {
  const MujocoWorld world(cal.cell, cal.box, real_robot, make_layout(cal.cell, cal.box, {}));
  LidarSetting lidar;
  lidar.apply(cal.cell.lidar_overrides, cal.cell.source);
  lidar.seed = lidar_seed;
  SweepOptions opt = options;
  opt.fixed_rays = nullptr, opt.fixed_ray_count = 0;  // rays shared by another cell's layouts do not apply
  const ScanLog log = simulate_sweep(world, real_robot, cal.program, lidar, opt).log;
  return calibrate_mount(log, nominal_robot, MountCalibrationSetting::for_box(cal.box_mesh), cal.cell.source);
}

}  // namespace weldtwin
