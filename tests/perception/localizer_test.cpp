// Localization: the pieces on synthetic data with known answers (voxel centroids, the table under outliers,
// the closed-form planar step, ICP from perturbed starts), the parts found at the 1 mm / 0.5 deg bar in twin
// scans and in the independent sample scans, wrong or missing parts refused, and bad input refused cleanly.
#include "perception/localizer.hpp"
#include "perception/localize/part_model_file.hpp"
#include "perception/localize/planar_fit.hpp"
#include "perception/localize/voxel_grid.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>

#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "perception/pose_error.hpp"
#include "perception/scan_assembly.hpp"
#include "sim/sweep_sim.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

using test::twin_scan;
using test::TwinScan;

constexpr double kSeamBar = 1e-3, kRotationBar = 0.5;  // the success bar: m, deg

TEST(Localizer, VoxelCentroidsAreTheMeansOfTheCubes) {
  // Two points in each of three 1 cm cubes, away from the cube faces: each centroid is the pair's mean.
  const std::vector<Vec3> points{{0.002, 0.003, 0.004}, {0.006, 0.007, 0.008}, {0.012, 0.001, 0.001},
                                 {0.018, 0.009, 0.003}, {0.031, 0.041, 0.051}, {0.033, 0.043, 0.055}};
  std::vector<Vec3> c = voxel_centroids(points, 0.01);
  ASSERT_EQ(c.size(), 3u);
  std::sort(c.begin(), c.end(), [](const Vec3& a, const Vec3& b) { return a.x() < b.x(); });
  for (int k = 0; k < 3; ++k)
    EXPECT_LT((c[static_cast<size_t>(k)] - 0.5 * (points[2 * k] + points[2 * k + 1])).norm(), 1e-7) << k;
}

TEST(Localizer, TablePlaneIsRecoveredUnderHalfOutliersAndAFloor) {
  // A tilted table (1.2 x 0.8 m, 1 mm noise), a bigger floor 0.8 m below it, and as many outliers as table
  // points spread through the volume above: the table, not the floor, to a fraction of the noise.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);
  const Vec3 n = Vec3(0.01, -0.02, 1.0).normalized();
  const double d = -0.015;  // n.x + d = 0
  std::vector<Vec3> pts;
  for (int i = 0; i < 20000; ++i) {
    const double x = -0.1 + 0.8 * u(rng), y = -0.6 + 1.2 * u(rng);
    const double z = (-d - n.x() * x - n.y() * y) / n.z();
    pts.push_back(Vec3(x, y, z) + noise(rng) * n);
  }
  for (int i = 0; i < 30000; ++i)
    pts.emplace_back(-1.1 + 2.2 * u(rng), -1.1 + 2.2 * u(rng), -0.8 + 0.001 * noise(rng));
  for (int i = 0; i < 20000; ++i) pts.emplace_back(-0.1 + 0.8 * u(rng), -0.6 + 1.2 * u(rng), 0.5 * u(rng));
  const TablePlane table = find_table_plane(pts);
  ASSERT_TRUE(table.found);
  const Eigen::Vector4d& plane = table.plane;
  const double sigma = table.noise_m;
  EXPECT_LT(std::acos(std::min(1.0, plane.head<3>().dot(n))), deg2rad(0.05));
  EXPECT_NEAR(plane[3], d, 2e-4);
  EXPECT_NEAR(sigma, 0.001, 3e-4);
}

TEST(Localizer, AWarpedTableGivesOnePlaneAndItsNoiseWhateverTheRansacProposed) {
  // A steel table is not flat to its noise: this one bows 2.5 mm along x and twists 1 mm (1 mm noise, heavier
  // tails: one point in fifty off by 4-10 mm, as a real table's scan), with boxes standing on it. The fit
  // settles on one plane and one noise: the cloud and its two interleaved halves (whose RANSACs propose other
  // planes) agree to a small fraction of the noise. (The fit had stopped after four rounds of a mask that
  // followed its narrowing band, masking more of the table every round: on the paper's real scan the two
  // halves' noise came out 1.0 and 2.0 mm from two RANSAC starts.)
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);
  auto warp = [](double x, double y) {
    const double sx = (x - 0.3) / 0.4, sy = y / 0.6;
    return 0.0025 * sx * sx + 0.001 * sx * sy;
  };
  std::vector<Vec3> pts;
  for (int i = 0; i < 60000; ++i) {
    const double x = -0.1 + 0.8 * u(rng), y = -0.6 + 1.2 * u(rng);
    const double tail = i % 50 == 0 ? (u(rng) < 0.5 ? -1 : 1) * (0.004 + 0.006 * u(rng)) : 0.0;
    pts.emplace_back(x, y, warp(x, y) + noise(rng) + tail);
  }
  for (int b = 0; b < 6; ++b) {  // boxes 60 x 60 x 50 mm: their walls' feet reach into any band
    const double cx = 0.05 * b + 0.1, cy = -0.4 + 0.15 * b;
    for (int i = 0; i < 1500; ++i) {
      const double t = u(rng), h = 0.05 * u(rng);
      const int side = i % 4;
      const double x = cx + (side == 0 ? -0.03 : side == 1 ? 0.03 : -0.03 + 0.06 * t);
      const double y = cy + (side == 2 ? -0.03 : side == 3 ? 0.03 : -0.03 + 0.06 * t);
      pts.emplace_back(x, y, warp(cx, cy) + h);
    }
  }
  std::vector<Vec3> half[2];
  for (size_t i = 0; i < pts.size(); ++i) half[i % 2].push_back(pts[i]);
  const TablePlane whole = find_table_plane(pts), a = find_table_plane(half[0]),
                   b = find_table_plane(half[1]);
  ASSERT_TRUE(whole.found && a.found && b.found);
  const Vec3 part(0.45, 0.1, 0.0);  // where a part would stand: the planes' heights there
  auto height = [&](const TablePlane& t) {
    return -(t.plane[3] + t.plane.head<2>().dot(part.head<2>())) / t.plane[2];
  };
  EXPECT_NEAR(height(a), height(whole), 1e-4);
  EXPECT_NEAR(height(b), height(whole), 1e-4);
  EXPECT_NEAR(a.noise_m, whole.noise_m, 0.03 * whole.noise_m);
  EXPECT_NEAR(b.noise_m, whole.noise_m, 0.03 * whole.noise_m);
  // The noise it reports is the table's own spread about a plane (noise and warp), not a fraction of it.
  EXPECT_GT(whole.noise_m, 0.0009);
  EXPECT_LT(whole.noise_m, 0.0016);
}

TEST(Localizer, PlanarRigidFitRecoversAKnownMotionExactly) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Iso3 T = planar_pose(0.3 * u(rng), 0.3 * u(rng), 0.0, kPi * u(rng));
    std::vector<Vec3> from, to;
    for (int i = 0; i < 30; ++i) {
      from.emplace_back(u(rng), u(rng), 0.1 * u(rng));
      to.push_back(T * from.back());
    }
    const Iso3 fit = planar_rigid_fit(from, to);
    EXPECT_LT((fit.matrix() - T.matrix()).norm(), 1e-12) << trial;
  }
}

TEST(Localizer, RefinementConvergesFromPerturbedStarts) {
  // Only the given start is refined (one hypothesis): from up to 10 mm and 5 deg away, the tee ends within
  // the bar every time.
  const TwinScan scan = twin_scan("scenes/cells/tube_tee.yaml", 2);
  const Mesh mesh = load_mesh(scan.part.mesh_path);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 6; ++trial) {
    LocalizeSetting s;
    s.use_initial_guess = true;
    s.search.hypotheses = 1;
    s.initial_guess = scan.truth * planar_pose(0.01 * u(rng), 0.01 * u(rng), 0.0, deg2rad(5.0) * u(rng));
    const PoseEstimate pose = localize(scan.cloud, mesh, s, {}, scan.viewpoints);
    ASSERT_TRUE(pose.found) << trial << ": " << pose.reason;
    const PoseError e = pose_error(scan.part, pose.T_base_part, scan.truth);
    EXPECT_LT(e.seam_max_m, kSeamBar) << trial;
    EXPECT_LT(rad2deg(e.rotation_rad), kRotationBar) << trial;
  }
}

TEST(Localizer, FindsEachPartInSeededTwinScansAtTheBar) {
  // Seeded cells (any yaw, clamps, clutter, default noise); the randomized survey in benchmarks/ measures
  // the whole distribution, these pin a few cases down.
  const std::pair<const char*, uint64_t> cases[] = {{"scenes/cells/default.yaml", 8},
                                                    {"scenes/cells/round_on_plate.yaml", 2},
                                                    {"scenes/cells/tube_tee.yaml", 6}};
  for (const auto& [file, seed] : cases) {
    const TwinScan scan = twin_scan(file, seed);
    const Mesh mesh = load_mesh(scan.part.mesh_path);
    const PoseEstimate pose =
        localize(scan.cloud, mesh, LocalizeSetting(), scan.part.seam_points(0.001), scan.viewpoints);
    ASSERT_TRUE(pose.found) << file << ": " << pose.reason;
    const PoseError e = pose_error(scan.part, pose.T_base_part, scan.truth, z_symmetry_order(mesh));
    std::printf("%s seed %llu: seam %.3f mm, rotation %.3f deg, %.2f s\n", scan.part.name.c_str(),
                static_cast<unsigned long long>(seed), 1e3 * e.seam_max_m, rad2deg(e.rotation_rad),
                pose.seconds);
    EXPECT_LT(e.seam_max_m, kSeamBar) << file;
    EXPECT_LT(rad2deg(e.rotation_rad), kRotationBar) << file;
    EXPECT_NEAR(pose.table_plane[3], 0.0, 2e-4);  // the table top is z = 0 of the base frame
  }
}

TEST(Localizer, NeverAcceptsAWrongOrMissingPart) {
  const TwinScan scan = twin_scan("scenes/cells/default.yaml", 3);  // tube_on_plate on the table
  for (const char* wrong : {"scenes/parts/tube_tee.stl", "scenes/parts/round_on_plate.stl"}) {
    const PoseEstimate pose = localize(scan.cloud, load_mesh(test::repo(wrong)));
    EXPECT_FALSE(pose.found) << wrong;
    EXPECT_FALSE(pose.reason.empty());
  }
  // The same scene with the part's points taken out: clamps and clutter stay.
  std::vector<Vec3> absent;
  for (size_t i = 0; i < scan.cloud.size(); ++i)
    if (scan.labels[i] != Label::kPart) absent.push_back(scan.cloud[i]);
  const PoseEstimate pose = localize(absent, load_mesh(scan.part.mesh_path));
  EXPECT_FALSE(pose.found) << "found a part that is not there";
}

TEST(Localizer, IndependentSamplesAreFoundAtTheBarOrRefusedNeverWrong) {
  // Scans from a generator that is not weldtwin's (one short pass, no viewpoints, tubes off-centre on their
  // plates): a pose beyond the bar must never be accepted, and all but one are found (the one whose tube
  // walls across y got three points each is refused as ambiguous).
  const std::string root = std::string(WELDTWIN_SOURCE_DIR) + "/../shared/samples";
  if (!std::filesystem::is_directory(root)) GTEST_SKIP() << "skipped: ../shared/samples not found";
  int checked = 0, found = 0;
  for (const auto& dir : std::filesystem::directory_iterator(root)) {
    if (!dir.is_directory()) continue;
    const std::string d = dir.path().string();
    const SampleTruth truth = read_sample_truth(d + "/truth.json");
    const Mesh mesh = load_mesh(d + "/part.stl");
    const PoseEstimate pose =
        localize(read_cloud(d + "/scan.pcd"), mesh, LocalizeSetting(), truth.part.seam_points(0.001));
    const PoseError e = pose_error(truth.part, pose.T_base_part, truth.T_base_part, z_symmetry_order(mesh));
    std::printf("%s: %s, seam %.3f mm, rotation %.3f deg, bound %.2f mm %s\n", dir.path().filename().c_str(),
                pose.found ? "found" : "refused", 1e3 * e.seam_max_m, rad2deg(e.rotation_rad),
                1e3 * pose.seam_error_bound_m, pose.reason.c_str());
    ++checked;
    if (!pose.found) {
      EXPECT_FALSE(pose.reason.empty()) << d;
      continue;
    }
    ++found;
    EXPECT_LT(e.seam_max_m, kSeamBar) << d;
    EXPECT_LT(rad2deg(e.rotation_rad), kRotationBar) << d;
  }
  EXPECT_GE(checked, 9);
  EXPECT_GE(found, checked - 1);
}

TEST(Localizer, TheRealTeeIsFoundWhereItWasPlacedAndOtherPartsAreRefused) {
  // The seed paper's real scan (an RPLIDAR A2 on an Aubo i5 over a steel table, the LiDAR mount not
  // calibrated, no viewpoints): found; after the calibration difference the paper published, within 6 mm
  // and 2 deg of where the part was placed by hand; the two interleaved halves of the points, localized
  // alone, put the seams within 0.5 mm of each other; other parts' meshes are refused.
  const std::string dir = std::string(WELDTWIN_SOURCE_DIR) + "/../shared/real/paper_rig";
  if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << "skipped: ../shared/real not found";
  const Mesh mesh = load_mesh(dir + "/tee.stl");
  const PartSpec part = PartSpec::load(test::repo("scenes/parts/paper_tee.yaml"));
  auto lowest = [](const Mesh& m) {
    double z = 1e9;
    for (const Vec3& v : m.vertices) z = std::min(z, v.z());
    return z;
  };
  std::vector<Vec3> seams = part.seam_points(0.001);  // our spec's frame rests on z = 0; the CAD's does not
  const double lift = lowest(mesh) - lowest(load_mesh(part.mesh_path));
  for (Vec3& s : seams) s.z() += lift;
  const std::vector<Vec3> cloud = read_cloud(dir + "/scan_tee_x4y24_45.pcd");
  const PoseEstimate pose = localize(cloud, mesh, LocalizeSetting(), seams);
  ASSERT_TRUE(pose.found) << pose.reason;
  // nominal.json: placed at (0.1016, -0.6096, 0.0254) m, yaw 45 deg; calibration difference (expected minus
  // measured) (-8.93, -0.86, +5.37) mm, yaw -0.04 deg.
  const Vec3 corrected = pose.T_base_part.translation() + Vec3(-0.00893, -0.00086, 0.00537);
  EXPECT_LT((corrected - Vec3(0.1016, -0.6096, 0.0254)).norm(), 0.006);
  const double yaw = std::atan2(pose.T_base_part.linear()(1, 0), pose.T_base_part.linear()(0, 0)) - 0.00071;
  EXPECT_LT(std::abs(rad2deg(std::remainder(yaw - 0.7854, 2 * kPi))), 2.0);
  // The cell's table known (the part placed on it at z = 0): the scan shows it several millimetres low under
  // the part, as the mount that the paper's calibration later found 5.4 mm off in z; refused for that.
  LocalizeSetting on_the_cells_table;
  on_the_cells_table.table.cell_top_z_m = 0.0;
  const PoseEstimate mount_off = localize(cloud, mesh, on_the_cells_table, seams);
  EXPECT_FALSE(mount_off.found);
  EXPECT_TRUE(mount_off.table_off);
  EXPECT_LT(mount_off.table.height_m, -0.004);
  EXPECT_GT(mount_off.table.height_m, -0.009);
  std::vector<Vec3> half[2];
  for (size_t i = 0; i < cloud.size(); ++i) half[i % 2].push_back(cloud[i]);
  const PoseEstimate a = localize(half[0], mesh, LocalizeSetting(), seams);
  const PoseEstimate b = localize(half[1], mesh, LocalizeSetting(), seams);
  double split = 0.0;
  for (const Vec3& s : seams) split = std::max(split, (a.T_base_part * s - b.T_base_part * s).norm());
  EXPECT_LT(split, 0.0005);
  for (const char* other : {"scenes/parts/tube_on_plate.stl", "scenes/parts/tube_tee.stl",
                            "scenes/parts/offset_tube_on_plate.stl", "scenes/parts/rect_tee_flat.stl"})
    EXPECT_FALSE(localize(cloud, load_mesh(test::repo(other))).found) << other;
}

TEST(Localizer, PoseErrorCountsOnlyWhatMovesTheSeams) {
  const PartSpec square = PartSpec::load(test::repo("scenes/parts/tube_on_plate.yaml"));
  const PartSpec round = PartSpec::load(test::repo("scenes/parts/round_on_plate.yaml"));
  const Iso3 truth = planar_pose(0.4, -0.1, 0.0, 0.3);
  // A quarter turn of the square tube puts its seams on themselves: no error.
  const PoseError quarter = pose_error(square, truth * planar_pose(0, 0, 0, kPi / 2), truth, 4);
  EXPECT_LT(quarter.seam_max_m, 1e-6);
  EXPECT_LT(quarter.rotation_rad, 1e-9);
  // 1 deg about the origin moves the square's seam corners by ~0.5 mm; a circle about its axis not at all.
  const PoseError turned = pose_error(square, truth * planar_pose(0, 0, 0, deg2rad(1)), truth, 4);
  EXPECT_NEAR(turned.rotation_rad, deg2rad(1), 1e-9);
  EXPECT_GT(turned.seam_max_m, 3e-4);
  const PoseError circle = pose_error(round, truth * planar_pose(0, 0, 0, deg2rad(17)), truth, 4);
  EXPECT_LT(circle.seam_max_m, 1e-5);
  EXPECT_LT(circle.rotation_rad, 1e-9);
  // A shift is a shift.
  const PoseError shifted = pose_error(square, planar_pose(0.0007, 0, 0, 0) * truth, truth, 4);
  EXPECT_NEAR(shifted.seam_max_m, 7e-4, 1e-6);
}

TEST(Localizer, SeamDistanceIsTheFarthestEitherWay) {
  // A 100 mm seam against one 0.3 mm to its side and 2 mm longer: 0.3 mm from it, but its last 2 mm are 2.02
  // mm from the first's end.
  std::vector<Vec3> a, b;
  for (int i = 0; i <= 1000; ++i) a.emplace_back(1e-4 * i, 0, 0);
  for (int i = 0; i <= 1020; ++i) b.emplace_back(1e-4 * i, 0.0003, 0);
  EXPECT_NEAR(seam_distance_m(a, b), std::hypot(0.002, 0.0003), 1e-12);
  EXPECT_NEAR(seam_distance_m(b, a), std::hypot(0.002, 0.0003), 1e-12);
  b.resize(1001);
  EXPECT_NEAR(seam_distance_m(a, b), 0.0003, 1e-12);
  EXPECT_TRUE(std::isinf(seam_distance_m(a, {})));
}

TEST(Localizer, BadInputIsRefusedCleanly) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_localizer_test";
  std::filesystem::create_directories(dir);
  const std::string empty = (dir / "empty.pcd").string(), cut = (dir / "cut.pcd").string(),
                    nan = (dir / "nan.pcd").string();
  std::ofstream(empty).close();
  EXPECT_THROW(read_cloud(empty), InputError);
  std::ofstream(cut)
      << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 100\n";
  EXPECT_THROW(read_cloud(cut), InputError);
  std::ofstream(nan)
      << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n"
         "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\nnan nan nan\n0.1 0.2 0.3\ninf 0 0\n";
  size_t dropped = 0;
  EXPECT_EQ(read_cloud(nan, &dropped).size(), 1u);
  EXPECT_EQ(dropped, 2u);
  EXPECT_THROW(load_mesh((dir / "missing.stl").string()), InputError);
  std::ofstream((dir / "junk.stl").string()) << "solid junk\nthis is not a mesh\n";
  EXPECT_THROW(load_mesh((dir / "junk.stl").string()), InputError);
  // A cloud without a table: no answer, a reason.
  std::vector<Vec3> sky;
  for (int i = 0; i < 1000; ++i) sky.emplace_back(0.3 + 0.001 * i, 0.0, 0.5 + 0.0003 * (i % 7));
  const PoseEstimate pose = localize(sky, load_mesh(test::repo("scenes/parts/tube_tee.stl")));
  EXPECT_FALSE(pose.found);
  EXPECT_NE(pose.reason.find("table"), std::string::npos) << pose.reason;
  // A scale (as --units mm gives) scales every vertex by the factor; scaled to 300 m, or to 0.3 mm (a mesh in
  // metres read as millimetres), it is no part.
  const Mesh m = load_mesh(test::repo("scenes/parts/tube_tee.stl"));
  const Mesh half = load_mesh(test::repo("scenes/parts/tube_tee.stl"), 0.5);
  EXPECT_NEAR(half.vertices[5].x(), 0.5 * m.vertices[5].x(), 1e-12);
  EXPECT_THROW(load_mesh(test::repo("scenes/parts/tube_tee.stl"), 1e3), InputError);
  EXPECT_THROW(load_mesh(test::repo("scenes/parts/tube_tee.stl"), 1e-3), InputError);
}

TEST(Localizer, RaysCastFromTheirViewpointsFindTheSquareTubeWhereItsPointsAloneDoNot) {
  // The square tube's 3.2 mm walls under ~2.1 mm range noise: from the points alone, which side of a wall a
  // point lies on is a guess (seed 25 lands 1.3 mm off), so without viewpoints the pose is refused or within
  // the bar, never wrong. Cast from where the LiDAR was, every ray meets its own face: within the bar.
  for (uint64_t seed : {23, 25, 28}) {
    const TwinScan scan = twin_scan("scenes/cells/default.yaml", seed);
    const Mesh mesh = load_mesh(scan.part.mesh_path);
    const std::vector<Vec3> seams = scan.part.seam_points(0.001);
    const PoseEstimate with = localize(scan.cloud, mesh, LocalizeSetting(), seams, scan.viewpoints);
    const PoseEstimate without = localize(scan.cloud, mesh, LocalizeSetting(), seams);
    ASSERT_TRUE(with.found) << seed << ": " << with.reason;
    const PoseError e = pose_error(scan.part, with.T_base_part, scan.truth, z_symmetry_order(mesh));
    const PoseError e0 = pose_error(scan.part, without.T_base_part, scan.truth, z_symmetry_order(mesh));
    std::printf("tube_on_plate seed %llu: with viewpoints %.3f mm %.3f deg, without %.3f mm %.3f deg\n",
                static_cast<unsigned long long>(seed), 1e3 * e.seam_max_m, rad2deg(e.rotation_rad),
                1e3 * e0.seam_max_m, rad2deg(e0.rotation_rad));
    EXPECT_LT(e.seam_max_m, kSeamBar) << seed;
    EXPECT_LT(rad2deg(e.rotation_rad), kRotationBar) << seed;
    if (without.found) {
      EXPECT_LT(e0.seam_max_m, kSeamBar) << seed << ": a confident wrong pose";
    }
    if (seed == 25) {
      EXPECT_FALSE(without.found) << "1.3 mm off without viewpoints";
    }
    EXPECT_TRUE(with.rays_cast);
    EXPECT_FALSE(without.rays_cast);
    if (seed != 23) continue;
    // Viewpoints that cannot be a LiDAR over the table (all zero, as some tools write them) are not used.
    const PoseEstimate zero = localize(scan.cloud, mesh, LocalizeSetting(), seams,
                                       std::vector<Vec3>(scan.cloud.size(), Vec3::Zero()));
    EXPECT_FALSE(zero.rays_cast);
    EXPECT_TRUE(zero.T_base_part.isApprox(without.T_base_part, 1e-12));
  }
}

// A command that refuses the cloud while the part is still being prepared (a malformed scan file) gives the
// part up mid-build: the build still keeps the model where it was asked to, under its own name, and nothing
// else (it once saved it under a freed path: a file named by heap bytes in the working directory).
TEST(Localizer, APartGivenUpWhileItsBuildRunsIsKeptWhereAsked) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("weldtwin_given_up_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const Mesh mesh = load_mesh(test::repo("scenes/parts/tube_on_plate.stl"));
  auto here = [&] {  // the working directory's entries, but for `dir` (it may lie there)
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(fs::current_path()))
      if (e.path().filename() != dir.filename()) names.insert(e.path().filename().string());
    return names;
  };
  const std::set<std::string> before = here();
  { const PreparedPart given_up(mesh, LocalizeSetting(), true, dir.string()); }
  std::vector<std::string> kept;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir)) kept.push_back(e.path().filename().string());
  EXPECT_EQ(here(), before);
  double min_z = 1e9;
  for (const Vec3& v : mesh.vertices) min_z = std::min(min_z, v.z());
  if (part_model_key(mesh, min_z, LocalizeSetting().model) == 0)
    GTEST_SKIP() << "this build has no build id: nothing is kept";
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].size(), 16u + 5u) << kept[0];  // 16 hex digits of the key, ".part"
  EXPECT_EQ(fs::path(kept[0]).extension(), ".part");
  fs::remove_all(dir);
}

TEST(Localizer, APreparedPartGivesTheMeshsAnswersScanAfterScan) {
  // One prepared part, used on a scan and then on another (its lookup grid already filled by the first):
  // the second answer is, to the bit, the one the mesh itself gives (that call builds its part on a thread
  // beside the table search). Prepared with another model spacing than the setting's, it is refused.
  const TwinScan first = twin_scan("scenes/cells/default.yaml", 3),
                 second = twin_scan("scenes/cells/default.yaml", 4);
  const Mesh mesh = load_mesh(first.part.mesh_path);
  const std::vector<Vec3> seams = first.part.seam_points(0.001);
  const PreparedPart part(mesh);
  const PoseEstimate warm = localize(first.cloud, part, LocalizeSetting(), seams, first.viewpoints);
  ASSERT_TRUE(warm.found) << warm.reason;
  const PoseEstimate reused = localize(second.cloud, part, LocalizeSetting(), seams, second.viewpoints);
  const PoseEstimate fresh = localize(second.cloud, mesh, LocalizeSetting(), seams, second.viewpoints);
  ASSERT_TRUE(fresh.found) << fresh.reason;
  EXPECT_EQ(reused.found, fresh.found);
  EXPECT_EQ(reused.reason, fresh.reason);
  EXPECT_TRUE(reused.T_base_part.matrix() == fresh.T_base_part.matrix());
  EXPECT_EQ(reused.fitness, fresh.fitness);
  EXPECT_EQ(reused.coverage, fresh.coverage);
  EXPECT_EQ(reused.ambiguity, fresh.ambiguity);
  EXPECT_EQ(reused.wall_residual, fresh.wall_residual);
  EXPECT_EQ(reused.iterations, fresh.iterations);
  // The two scans are of different layouts: equal answers are not equal inputs.
  EXPECT_GT((warm.T_base_part.translation() - reused.T_base_part.translation()).norm(), 0.01);
  LocalizeSetting coarse;
  coarse.model.spacing_m = 0.004;
  EXPECT_THROW(localize(second.cloud, part, coarse), std::invalid_argument);
}

TEST(Localizer, CloudFilesCarryTheViewpointOfEveryPoint) {
  // Written with viewpoints: PCL's x y z vp_x vp_y vp_z, read back point for point (binary and ascii).
  // Without them (and from a file without those fields) no viewpoints. A row with a non-finite viewpoint is
  // dropped with its point.
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_localizer_test";
  std::filesystem::create_directories(dir);
  const std::vector<Vec3> pts{{0.1, 0.2, 0.3}, {-0.4, 0.5, 0.025}, {0.7, -0.8, 0.9}};
  const std::vector<Vec3> vps{{0.0, 0.1, 0.5}, {0.2, 0.3, 0.6}, {-0.1, 0.0, 0.45}};
  for (bool ascii : {false, true}) {
    const std::string file = (dir / (ascii ? "vp_ascii.pcd" : "vp_binary.pcd")).string();
    write_pcd(file, pts, ascii, &vps);
    std::vector<Vec3> got_vp;
    const std::vector<Vec3> got = read_cloud(file, nullptr, &got_vp);
    ASSERT_EQ(got.size(), pts.size());
    ASSERT_EQ(got_vp.size(), vps.size());
    for (size_t i = 0; i < pts.size(); ++i) {
      EXPECT_LT((got[i] - pts[i]).norm(), 1e-6) << i;
      EXPECT_LT((got_vp[i] - vps[i]).norm(), 1e-6) << i;
    }
  }
  const std::string plain = (dir / "plain.pcd").string();
  write_pcd(plain, pts);
  std::vector<Vec3> none{{1, 2, 3}};
  EXPECT_EQ(read_cloud(plain, nullptr, &none).size(), pts.size());
  EXPECT_TRUE(none.empty());
  EXPECT_THROW(write_pcd(plain, pts, false, &none), std::invalid_argument);
  const std::string bad = (dir / "bad_vp.pcd").string();
  std::ofstream(bad) << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z vp_x vp_y vp_z\nSIZE 4 4 4 4 4 4\n"
                        "TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
                        "POINTS 2\nDATA ascii\n0.1 0.2 0.3 0 0 nan\n0.4 0.5 0.6 0 0 1\n";
  size_t dropped = 0;
  std::vector<Vec3> vp;
  const std::vector<Vec3> kept = read_cloud(bad, &dropped, &vp);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(dropped, 1u);
  EXPECT_LT((kept[0] - Vec3(0.4, 0.5, 0.6)).norm(), 1e-6);
  EXPECT_LT((vp.at(0) - Vec3(0, 0, 1)).norm(), 1e-6);
}

// The command line on big and odd clouds: 5 million points of bare table (an answer: not found, exit 3, the
// reason in the JSON), a cloud with no table (exit 3), an unknown method (exit 2).
TEST(Localizer, CommandLineCopesWithFiveMillionPointsAndNoTable) {
  const auto dir = std::filesystem::temp_directory_path() / "weldtwin_localizer_test";
  std::filesystem::create_directories(dir);
  const std::string big = (dir / "big.pcd").string(), sky = (dir / "sky.pcd").string();
  auto write = [](const std::string& path, const std::vector<float>& xyz) {
    std::ofstream out(path, std::ios::binary);
    const size_t n = xyz.size() / 3;
    out << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " << n
        << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
    out.write(reinterpret_cast<const char*>(xyz.data()),
              static_cast<std::streamsize>(xyz.size() * sizeof(float)));
  };
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.0015f);
  std::vector<float> xyz;
  xyz.reserve(15000000);
  for (int i = 0; i < 5000000; ++i) {
    xyz.push_back(-0.1f + 0.8f * u(rng));
    xyz.push_back(-0.6f + 1.2f * u(rng));
    xyz.push_back(noise(rng));
  }
  write(big, xyz);
  xyz.clear();
  for (int i = 0; i < 3000; ++i) xyz.insert(xyz.end(), {0.3f + 0.0001f * i, 0.0f, 0.5f + 0.0003f * (i % 7)});
  write(sky, xyz);
  const std::string model = test::repo("scenes/parts/tube_on_plate.stl");
  auto run = [&](const std::string& scan, const std::string& extra) {
    const std::string out = (dir / "pose.json").string();
    std::filesystem::remove(out);
    const std::string cmd = std::string(WELDTWIN_BINARY) + " localize -q --model " + model + " --scan " +
                            scan + " --out " + out + " " + extra + " 2>" + (dir / "err.txt").string();
    const int status = std::system(cmd.c_str());
    std::ifstream in(out);
    const std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return std::make_pair(WEXITSTATUS(status), json);
  };
  const auto [big_code, big_json] = run(big, "");
  EXPECT_EQ(big_code, 3);
  EXPECT_NE(big_json.find("\"found\": false"), std::string::npos);
  const auto [sky_code, sky_json] = run(sky, "");
  EXPECT_EQ(sky_code, 3);
  EXPECT_NE(sky_json.find("no table"), std::string::npos) << sky_json;
  EXPECT_EQ(run(sky, "--method guess").first, 2);
}

}  // namespace
}  // namespace weldtwin
