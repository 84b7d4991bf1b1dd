// A simulated sweep: every exact point lies on the geom it is labelled with (checked with geometry written
// independently of the ray casters), the part gets enough points, the noise model has the stated statistics,
// and a seed reproduces a sweep bit for bit.
#include "sim/sweep_sim.hpp"
#include "core/error.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <map>

#include "sim/seam_coverage.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

// ---- independent geometry: distance from a point to a primitive's surface, in the geom frame ----
double box_surface(const Vec3& p, const Vec3& s) {
  const Vec3 q = p.cwiseAbs() - s;
  return std::abs(q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0));
}
double cylinder_surface(const Vec3& p, double r, double h) {
  const Eigen::Vector2d q(std::hypot(p.x(), p.y()) - r, std::abs(p.z()) - h);
  return std::abs(q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0));
}
double triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Closest point on a triangle by its Voronoi regions.
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}
std::vector<std::array<Vec3, 3>> read_binary_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char header[80];
  uint32_t n = 0;
  in.read(header, 80);
  in.read(reinterpret_cast<char*>(&n), 4);
  std::vector<std::array<Vec3, 3>> tris(n);
  for (auto& t : tris) {
    float f[12];
    uint16_t attr;
    in.read(reinterpret_cast<char*>(f), sizeof f);
    in.read(reinterpret_cast<char*>(&attr), 2);
    for (int v = 0; v < 3; ++v) t[static_cast<size_t>(v)] = Vec3(f[3 + 3 * v], f[4 + 3 * v], f[5 + 3 * v]);
  }
  return tris;
}

Iso3 geom_pose(const mjData* d, int g) {
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = d->geom_xmat[9 * g + 3 * r + c];
  return make_transform(Vec3(d->geom_xpos[3 * g], d->geom_xpos[3 * g + 1], d->geom_xpos[3 * g + 2]), R);
}

Iso3 body_pose(const mjData* d, int b) {
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = d->xmat[9 * b + 3 * r + c];
  return make_transform(Vec3(d->xpos[3 * b], d->xpos[3 * b + 1], d->xpos[3 * b + 2]), R);
}

Vec3 sample_point(const SweepResult& r, size_t i) {
  const LidarSample& s = r.log.samples[i];
  return r.T_base_lidar[i] * Vec3(s.range_m * std::cos(s.angle_rad), s.range_m * std::sin(s.angle_rad), 0.0);
}

TEST(SweepSim, NoiseFreePointsLieOnTheirLabelledGeoms) {
  test::Cell cell("scenes/cells/round_on_plate.yaml");
  const MujocoWorld& w = *cell.world;
  const mjModel* m = w.model();
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  SweepOptions options;
  options.record_sensor_poses = true;
  options.max_duration_s = 45.0;  // three passes and their transitions
  const SweepResult r = simulate_sweep(w, cell.robot, program, LidarSetting().noise_free(), options);

  // The part mesh as the file has it, placed at the layout's pose.
  std::vector<std::array<Vec3, 3>> part = read_binary_stl(cell.part.mesh_path);
  for (auto& t : part)
    for (auto& v : t) v = cell.layout.T_base_part * v;

  // The arm's meshes as their files have them, in their link's frame (the geom "LINK_meshK" draws the link's
  // K-th mesh).
  std::map<int, std::vector<std::array<Vec3, 3>>> link_meshes;
  for (int g = 0; g < m->ngeom; ++g) {
    const char* name = mj_id2name(m, mjOBJ_GEOM, g);
    if (m->geom_type[g] != mjGEOM_MESH || w.geom_label(g) != Label::kRobot || !measured_for_clearance(m, g))
      continue;
    const std::string n = name;
    const size_t at = n.rfind("_mesh");
    ASSERT_NE(at, std::string::npos) << n;
    const RobotLink& link = cell.robot.links()[static_cast<size_t>(cell.robot.require_link(n.substr(0, at)))];
    const LinkMesh& mesh = link.collision_meshes.at(std::stoul(n.substr(at + 5)));
    auto& tris = link_meshes[g] = read_binary_stl(mesh.path);
    for (auto& t : tris)
      for (auto& v : t) v = mesh.T_link_mesh * v.cwiseProduct(mesh.scale);
  }
  ASSERT_FALSE(link_meshes.empty());

  DataPtr d = w.make_data();
  double worst[6] = {0, 0, 0, 0, 0, 0};
  size_t counted[6] = {0, 0, 0, 0, 0, 0};
  for (size_t i = 0; i < r.log.samples.size(); ++i) {
    const int g = r.geoms[i];
    if (g < 0) continue;
    // Moving geoms are posed at the start of the sample's slice; static ones never move.
    const double t_slice = std::floor(r.log.samples[i].t_s / options.slice_s) * options.slice_s;
    if (m->body_weldid[m->geom_bodyid[g]] != 0 || counted[0] == 0) w.set_joints(d.get(), program.q(t_slice));
    const Vec3 p = sample_point(r, i);
    const Iso3 T_geom_world = geom_pose(d.get(), g).inverse();
    const Vec3 local = T_geom_world * p;
    const mjtNum* s = m->geom_size + 3 * g;
    double dist = 1e9;
    switch (m->geom_type[g]) {
      case mjGEOM_BOX:
        dist = box_surface(local, Vec3(s[0], s[1], s[2]));
        break;
      case mjGEOM_CYLINDER:
        dist = cylinder_surface(local, s[0], s[1]);
        break;
      case mjGEOM_PLANE:
        dist = std::abs(local.z());
        break;
      case mjGEOM_MESH:
        if (link_meshes.count(g)) {
          const int b = m->geom_bodyid[g];
          const Vec3 in_link = body_pose(d.get(), b).inverse() * p;
          for (const auto& t : link_meshes[g])
            dist = std::min(dist, triangle_distance(in_link, t[0], t[1], t[2]));
        } else if (w.geom_label(g) == Label::kRobot) {
          // A visual mesh (COLLADA, which the test has no reader of): the triangles MuJoCo holds, geom frame.
          const int mesh = m->geom_dataid[g];
          const float* v = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
          const int* f = m->mesh_face + 3 * m->mesh_faceadr[mesh];
          auto vertex = [&](int k) { return Vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2]); };
          for (int k = 0; k < m->mesh_facenum[mesh]; ++k)
            dist = std::min(
                dist, triangle_distance(local, vertex(f[3 * k]), vertex(f[3 * k + 1]), vertex(f[3 * k + 2])));
        } else {
          for (const auto& t : part) dist = std::min(dist, triangle_distance(p, t[0], t[1], t[2]));
        }
        break;
      default:
        FAIL() << "unexpected geom type " << m->geom_type[g];
    }
    const size_t label = static_cast<size_t>(r.labels[i]);
    ASSERT_EQ(r.labels[i], w.geom_label(g));
    worst[label] = std::max(worst[label], dist);
    ++counted[label];
    ++counted[0];
  }
  std::printf(
      "points checked: part %zu (worst %.1e m), table %zu (%.1e), clamp %zu (%.1e), robot %zu (%.1e), "
      "other %zu (%.1e)\n",
      counted[1], worst[1], counted[2], worst[2], counted[3], worst[3], counted[4], worst[4], counted[5],
      worst[5]);
  for (int l = 1; l < 6; ++l) {
    EXPECT_GT(counted[l], 100u) << label_name(static_cast<Label>(l));
    EXPECT_LT(worst[l], 1e-6) << label_name(static_cast<Label>(l));
  }
}

TEST(SweepSim, EveryPartGetsEnoughPointsAndItsSeamsAreSeen) {
  for (const char* file :
       {"scenes/cells/default.yaml", "scenes/cells/round_on_plate.yaml", "scenes/cells/tube_tee.yaml"}) {
    test::Cell cell(file);
    const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
    const SweepResult r = simulate_sweep(*cell.world, cell.robot, program, LidarSetting().noise_free());
    std::vector<Vec3> part_points;
    SweepOptions none;
    for (size_t i = 0; i < r.labels.size(); ++i) {
      if (r.labels[i] != Label::kPart) continue;
      const LidarSample& s = r.log.samples[i];
      JointVector q = program.q(s.t_s);
      const Iso3 T = cell.robot.forward_kinematics(q, cell.robot.require_link("lidar"));
      part_points.push_back(T *
                            Vec3(s.range_m * std::cos(s.angle_rad), s.range_m * std::sin(s.angle_rad), 0.0));
    }
    std::printf("%s: %zu part points;", cell.part.name.c_str(), part_points.size());
    EXPECT_GT(part_points.size(), 2000u) << file;
    for (const SeamCoverage& c : seam_coverage(cell.part, cell.layout.T_base_part, part_points)) {
      // Seen from the open side: points on the joint's members within 8 mm of nearly every seam station.
      std::printf(" %s %.0f %% (both members %.0f %%)", c.seam.c_str(), 100 * c.fraction_one(),
                  100 * c.fraction());
      EXPECT_GE(c.fraction_one(), 0.7) << file << " seam " << c.seam;
    }
    std::printf("\n");
  }
}

TEST(SweepSim, CullingArmShapesByScanPlaneChangesNothing) {
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  SweepOptions options;
  options.max_duration_s = 40.0;  // passes and transitions
  const SweepResult a = simulate_sweep(*cell.world, cell.robot, program, LidarSetting(), options);
  options.cull_by_scan_plane = false;
  const SweepResult b = simulate_sweep(*cell.world, cell.robot, program, LidarSetting(), options);
  size_t robot = 0;
  for (size_t i = 0; i < a.log.samples.size(); ++i) {
    ASSERT_EQ(a.log.samples[i].range_m, b.log.samples[i].range_m) << i;
    ASSERT_EQ(a.geoms[i], b.geoms[i]) << i;
    robot += a.labels[i] == Label::kRobot;
  }
  EXPECT_GT(robot, 1000u);  // the arm is in view, so the culling had something to get wrong
}

// The rays and their hits on what every layout shares, cast in one layout, serve another: its sweep cast
// against its own part, clamps and clutter only is the sweep cast against everything.
TEST(SweepSim, FixedRaysOfAnotherLayoutGiveTheSameSweep) {
  test::Cell first("scenes/cells/tube_tee.yaml", 11);
  test::Cell cell("scenes/cells/tube_tee.yaml", 12);
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  LidarSetting lidar;
  lidar.mixed_pixels = true;
  lidar.seed = 5;
  SweepOptions options;
  options.max_duration_s = 60.0;  // passes, transitions, the arm in view
  std::vector<FixedRay> fixed(sweep_sample_count(program, lidar, options));
  cast_fixed_rays(*first.world, first.robot, program, lidar, options, fixed.data());
  const SweepResult all = simulate_sweep(*cell.world, cell.robot, program, lidar, options);
  ASSERT_EQ(all.log.samples.size(), fixed.size());
  options.fixed_rays = fixed.data();
  options.fixed_ray_count = fixed.size();
  const SweepResult some = simulate_sweep(*cell.world, cell.robot, program, lidar, options);
  const mjModel* m = cell.world->model();
  size_t placed = 0, robot = 0, table = 0, ties = 0;
  for (size_t i = 0; i < all.log.samples.size(); ++i) {
    ASSERT_EQ(all.log.samples[i].range_m, some.log.samples[i].range_m) << i;
    ASSERT_EQ(all.log.samples[i].quality, some.log.samples[i].quality) << i;
    ASSERT_EQ(all.log.samples[i].t_s, some.log.samples[i].t_s) << i;
    ASSERT_EQ(all.labels[i], some.labels[i]) << i;
    // Where two geoms of one body share a face (a clamp's arm on its post), which of them a ray meets first,
    // at the same range, is the ray tracer's tie (its hierarchy differs with the scene and the CPU).
    if (all.geoms[i] != some.geoms[i]) {
      ASSERT_GE(all.geoms[i], 0) << i;
      ASSERT_GE(some.geoms[i], 0) << i;
      ASSERT_EQ(m->geom_bodyid[all.geoms[i]], m->geom_bodyid[some.geoms[i]]) << i;
      ++ties;
    }
    placed += all.geoms[i] >= 0 && cell.world->placed_by_layout(all.geoms[i]);
    robot += all.labels[i] == Label::kRobot;
    table += all.labels[i] == Label::kTable;
  }
  // Each source of hits had plenty to get wrong: the layout's geoms, the arm, the table (which the part and
  // clamps of `first` shade where `cell`'s do not).
  EXPECT_GT(placed, 5000u);
  EXPECT_GT(robot, 1000u);
  EXPECT_GT(table, 20000u);
  EXPECT_LT(ties, all.log.samples.size() / 1000);
  // Rays of another sweep are refused.
  options.fixed_ray_count = fixed.size() - 1;
  EXPECT_THROW(simulate_sweep(*cell.world, cell.robot, program, lidar, options), std::invalid_argument);
}

TEST(SweepSim, SensorPosedAtKnotsAndInterpolatedIsWithinAMicrometreOfPosedAtEverySample) {
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  SweepOptions options;
  options.max_duration_s = 24.0;  // a pass at full speed, its blends and a transition
  options.record_sensor_poses = true;
  const LidarSetting exact_ranges = LidarSetting().noise_free();
  options.sensor_knot_samples = 1;
  const SweepResult every = simulate_sweep(*cell.world, cell.robot, program, exact_ranges, options);
  options.sensor_knot_samples = 8;
  const SweepResult knots = simulate_sweep(*cell.world, cell.robot, program, exact_ranges, options);
  ASSERT_EQ(every.log.samples.size(), knots.log.samples.size());
  double worst_m = 0.0, worst_rotation = 0.0, worst_between = 0.0;
  size_t ranges = 0, same = 0;
  for (size_t i = 0; i < every.T_base_lidar.size(); ++i) {
    const Iso3 &a = every.T_base_lidar[i], &b = knots.T_base_lidar[i];
    worst_m = std::max(worst_m, (a.translation() - b.translation()).norm());
    worst_rotation = std::max(worst_rotation, (a.linear() - b.linear()).norm());
    if (i % 8 != 0) worst_between = std::max(worst_between, (a.translation() - b.translation()).norm());
    const float ra = every.log.samples[i].range_m, rb = knots.log.samples[i].range_m;
    if (ra > 0 && rb > 0) ++ranges, same += std::abs(ra - rb) < 1e-6f * std::max(1.0f, ra);  // um a metre
  }
  std::printf("knots every 8 samples: sensor %.2e m, rotation %.2e; %zu of %zu ranges within 1 um a metre\n",
              worst_m, worst_rotation, same, ranges);
  EXPECT_LT(worst_m, 1e-6);
  EXPECT_LT(worst_rotation, 1e-6);
  EXPECT_GT(worst_between, 0.0);  // interpolated, not posed exactly: the comparison compares something
  EXPECT_GT(ranges, 50000u);
  EXPECT_GT(same, ranges * 999 / 1000);
}

TEST(SweepSim, RangeNoiseHasTheStatedSigmaAndSeedsReproduce) {
  test::Cell cell;
  const SweepProgram program = SweepProgram::load(cell.spec.sweep_program, cell.robot);
  SweepOptions options;
  options.max_duration_s = 10.0;
  LidarSetting noisy;
  noisy.mixed_pixels = noisy.grazing_dropouts = noisy.random_dropouts = false;
  noisy.quantize = false;
  const SweepResult exact = simulate_sweep(*cell.world, cell.robot, program, noisy.noise_free(), options);
  const SweepResult a = simulate_sweep(*cell.world, cell.robot, program, noisy, options);
  // Normalised residuals (measured - exact) / sigma(range) must be standard normal.
  double sum = 0, sum2 = 0;
  size_t n = 0;
  for (size_t i = 0; i < a.log.samples.size(); ++i) {
    const double r0 = exact.log.samples[i].range_m, r1 = a.log.samples[i].range_m;
    if (r0 <= 0 || r1 <= 0) continue;
    const double z = (r1 - r0) / (noisy.noise_sigma_m + noisy.noise_sigma_rel * r0);
    sum += z;
    sum2 += z * z;
    ++n;
  }
  ASSERT_GT(n, 10000u);
  const double mean = sum / static_cast<double>(n),
               sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.03);
  EXPECT_NEAR(sd, 1.0, 0.03);

  // Full default model, twice with one seed and once with another, on different thread counts.
  LidarSetting full;
  full.seed = 42;
  options.threads = 1;
  const SweepResult b1 = simulate_sweep(*cell.world, cell.robot, program, full, options);
  options.threads = 2;
  const SweepResult b2 = simulate_sweep(*cell.world, cell.robot, program, full, options);
  full.seed = 43;
  const SweepResult c = simulate_sweep(*cell.world, cell.robot, program, full, options);
  size_t differ = 0, mixed = 0, dropped = 0;
  for (size_t i = 0; i < b1.log.samples.size(); ++i) {
    ASSERT_EQ(b1.log.samples[i].range_m, b2.log.samples[i].range_m) << i;
    differ += b1.log.samples[i].range_m != c.log.samples[i].range_m;
    mixed += b1.labels[i] == Label::kOther && b1.geoms[i] < 0;
    dropped += b1.log.samples[i].range_m == 0 && exact.log.samples[i].range_m > 0;
    // Quantised to the A2's 0.25 mm steps.
    const double steps = b1.log.samples[i].range_m / 0.00025;
    EXPECT_NEAR(steps, std::round(steps), 1e-2);
  }
  EXPECT_GT(differ, b1.log.samples.size() / 4);
  EXPECT_GT(mixed, 10u);
  EXPECT_GT(dropped, 10u);
}

// LiDAR settings no scanner has are refused naming the setting (a turn rate of 1e-9 Hz had asked for a
// vector beyond max_size in a sweep thread; 1e6 Hz had eaten all memory).
TEST(LidarSetting, ValuesNoScannerHasAreRefused) {
  const std::vector<std::pair<std::string, double>> bad = {
      {"turn_rate_hz", 1e-9},         {"turn_rate_hz", 1e6},
      {"sample_rate_hz", 1e9},        {"sample_rate_hz", 5.0},
      {"max_range_m", 1e6},           {"noise_sigma_m", -0.001},
      {"mixed_pixel_probability", 2}, {"stray_return_probability", -1}};
  for (const auto& [key, value] : bad) {
    LidarSetting s;
    try {
      s.apply({{key, value}}, "cell.yaml");
      ADD_FAILURE() << key << " = " << value << " was taken";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cell.yaml"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  LidarSetting fine;  // an A2's own figures pass
  EXPECT_NO_THROW(fine.apply({{"turn_rate_hz", 15.0}, {"sample_rate_hz", 8000.0}}, "cell.yaml"));
}

// A program of 10,000 moves (hours of sweeping) had eaten all memory for its log; refused by its length.
TEST(SweepProgram, ProgramsOfHoursAreRefused) {
  const RobotModel robot = RobotModel::load(test::repo("scenes/robots/aubo_i5.urdf"));
  JointVector a = JointVector::Zero(), b = JointVector::Zero();
  a[1] = 0.2;
  b[1] = 0.25;
  std::vector<SweepMove> moves;
  for (int i = 0; i < 10000; ++i) moves.push_back({"m" + std::to_string(i), i % 2 ? a : b, 0.5});
  try {
    SweepProgram("long.yaml", a, moves, 0.2, 100.0, robot);
    FAIL() << "taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("long.yaml: the sweep lasts 5000 s (10000 moves)"),
              std::string::npos)
        << e.what();
  }
  moves.resize(100);  // 50 s
  EXPECT_NEAR(SweepProgram("short.yaml", a, moves, 0.2, 100.0, robot).duration_s(), 50.0, 1e-9);
}

}  // namespace
}  // namespace weldtwin
