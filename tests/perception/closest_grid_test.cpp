// The grid of candidate faces must answer exactly as the mesh does: the same nearest distance everywhere
// (inside its cells, where it stops, beyond it), the same "nothing within max_m", from several threads, and
// with the coarse cells a large part is given.
#include "perception/localize/closest_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <thread>

#include "tests/support/test_meshes.hpp"

namespace weldtwin {
namespace {

// A UV sphere of radius r with `around` x `up` quads, outward: its nearest face changes every few
// millimetres, so that a cell whose faces were chosen too tightly shows.
Mesh sphere(double r, int around, int up) {
  Mesh m;
  for (int j = 0; j <= up; ++j)
    for (int i = 0; i < around; ++i) {
      const double th = kPi * j / up, ph = 2 * kPi * i / around;
      m.vertices.emplace_back(r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph),
                              r * std::cos(th));
    }
  auto at = [&](int i, int j) { return j * around + (i % around); };
  for (int j = 0; j < up; ++j)
    for (int i = 0; i < around; ++i) {
      m.faces.emplace_back(at(i, j), at(i, j + 1), at(i + 1, j + 1));
      m.faces.emplace_back(at(i, j), at(i + 1, j + 1), at(i + 1, j));
    }
  return m;
}

void expect_same_answers(const MeshRays& rays, const ClosestGrid& grid, unsigned seed, double spread_m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-spread_m, spread_m), reach(0.0005, 0.03);
  int answered = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double max_m = reach(rng);
    Vec3 a, na, b, nb;
    const bool mesh = rays.closest(p, max_m, a, na);
    const bool fast = grid.closest(p, max_m, b, nb);
    ASSERT_EQ(mesh, fast) << p.transpose() << " within " << max_m;
    if (!mesh) continue;
    ++answered;
    ASSERT_NEAR((a - p).norm(), (b - p).norm(), 1e-12) << p.transpose();
    // Where two faces are equally near (an edge), either may answer: the point is the same, the normal that
    // of a face through it.
    ASSERT_LT((a - b).norm(), 1e-9) << p.transpose();
    ASSERT_NEAR(nb.norm(), 1.0, 1e-9);
  }
  EXPECT_GT(answered, 2000) << "the draws must reach the surface often";
}

TEST(ClosestGrid, AnswersAsTheMeshDoesInAndAroundItsCells) {
  const Mesh m = sphere(0.05, 48, 24);
  const MeshRays rays(m);
  ClosestGridSetting s;
  s.cell_m = 0.004;
  s.margin_m = 0.01;  // the grid stops 1 cm beyond the sphere's box; the draws go 3 cm beyond
  const ClosestGrid grid(rays, Vec3::Constant(-0.05), Vec3::Constant(0.05), s);
  expect_same_answers(rays, grid, 1, 0.08);
}

TEST(ClosestGrid, LargeCellsForALargePartGiveTheSameAnswers) {
  const Mesh m = sphere(0.05, 48, 24);
  const MeshRays rays(m);
  ClosestGridSetting s;
  s.max_cells = 1000;  // 10 x 10 x 10 cells over the sphere: 1.4 cm each
  const ClosestGrid grid(rays, Vec3::Constant(-0.05), Vec3::Constant(0.05), s);
  EXPECT_GT(grid.cell_m(), 0.013);
  expect_same_answers(rays, grid, 2, 0.07);
}

using test::cube_mesh;

TEST(ClosestGrid, BeyondAnEdgeTheFaceInFrontGivesTheNormal) {
  const double h = 0.05;
  const Mesh m = cube_mesh(h);
  const MeshRays rays(m);
  const ClosestGrid grid(rays, Vec3::Constant(-h), Vec3::Constant(h), ClosestGridSetting{});
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> along(-0.04, 0.04), out(0.0005, 0.008);
  for (int k = 0; k < 2000; ++k) {
    // Beyond the edge x = y = h, more in front of one face than the other; and beyond a vertex.
    const double a = out(rng), b = out(rng);
    if (std::abs(a - b) < 1e-4) continue;
    const Vec3 p(h + a, h + b, along(rng));
    Vec3 at, n;
    ASSERT_TRUE(grid.closest(p, 0.02, at, n));
    EXPECT_NEAR((at - Vec3(h, h, p.z())).norm(), 0.0, 1e-12);
    EXPECT_NEAR(n.dot(a > b ? Vec3::UnitX() : Vec3::UnitY()), 1.0, 1e-12) << p.transpose();
    const Vec3 v(h + a, h + b, h + out(rng));
    ASSERT_TRUE(grid.closest(v, 0.03, at, n));
    const Vec3 off = v - Vec3::Constant(h);
    Eigen::Index most = 0;
    off.maxCoeff(&most);
    EXPECT_NEAR(n[most], 1.0, 1e-12) << v.transpose();
  }
}

TEST(ClosestGrid, ThreadsFillingTheSameCellsAgree) {
  const Mesh m = sphere(0.05, 32, 16);
  const MeshRays rays(m);
  const ClosestGrid grid(rays, Vec3::Constant(-0.05), Vec3::Constant(0.05), ClosestGridSetting{});
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < 4; ++t) pool.emplace_back([&] { expect_same_answers(rays, grid, 7, 0.06); });
  for (std::thread& th : pool) th.join();
}

// The slots the lazily filled grids live in: all zero at first, whatever their size (small pages, or 2 MB
// ones from their boundary), holding what is written, and given back when dropped.
TEST(ZeroedSlots, StartAtZeroHoldWhatIsWrittenAndAreGivenBack) {
  for (size_t n : {size_t{1}, size_t{1000}, (kHugePageArray_bytes / sizeof(int)) - 1,
                   3 * kHugePageArray_bytes / sizeof(int) + 7}) {
    ZeroedSlots<int> slots = zeroed_slots<int>(n);
    ASSERT_TRUE(slots) << n;
    for (size_t i = 0; i < n; i += 997) ASSERT_EQ(slots[i], 0) << n << " slot " << i;
    EXPECT_EQ(slots[n - 1], 0) << n;
    if (n * sizeof(int) >= kHugePageArray_bytes) {
      EXPECT_EQ(reinterpret_cast<uintptr_t>(slots.get()) % (size_t{2} << 20), 0u) << "a 2 MB page boundary";
    }
    for (size_t i = 0; i < n; i += 4099) slots[i] = static_cast<int>(i % 1000) + 1;
    slots[n - 1] = -5;
    for (size_t i = 0; i + 1 < n; i += 4099) ASSERT_EQ(slots[i], static_cast<int>(i % 1000) + 1);
    EXPECT_EQ(slots[n - 1], -5);
  }
  const auto mapped_bytes = [] {  // the process's address space (the first field of /proc/self/statm)
    std::ifstream statm("/proc/self/statm");
    size_t pages = 0;
    statm >> pages;
    return pages * 4096;
  };
  const size_t before = mapped_bytes();
  for (int k = 0; k < 200; ++k) {  // 200 x 64 MB: 12.8 GB of address space if none were given back
    ZeroedSlots<uint64_t> big = zeroed_slots<uint64_t>(size_t{8} << 20);
    big[size_t{8} << 19] = 1;
  }
  EXPECT_LT(mapped_bytes(), before + (size_t{256} << 20));
}

}  // namespace
}  // namespace weldtwin
