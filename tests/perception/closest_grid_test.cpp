// The grid of candidate faces must answer exactly as the mesh does: the same nearest distance everywhere
// (inside its cells, where it stops, beyond it), the same "nothing within max_m", from several threads, and
// with the coarse cells a large part is given.
#include "perception/localize/closest_grid.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <set>
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

// The bricks the lookup grids keep their slots in: zero until written, each cell its own slot (neighbours
// across a brick's faces too), only the bricks asked about made, and one brick per place whoever asks first.
TEST(BrickSlots, CellsAreZeroUntilWrittenAndOnlyBricksAskedAboutAreMade) {
  BrickSlots<int> slots(37, 5, 19);  // not a whole number of bricks along any axis
  EXPECT_EQ(slots.bricks_made(), 0u);
  for (long z = 0; z < 19; ++z)
    for (long y = 0; y < 5; ++y)
      for (long x = 0; x < 37; ++x) ASSERT_EQ(*slots.slot(x, y, z), 0) << x << " " << y << " " << z;
  const size_t all = slots.bricks_made();
  EXPECT_EQ(all, static_cast<size_t>(((37 + 3) / 4) * ((5 + 3) / 4) * ((19 + 3) / 4)));
  for (long z = 0; z < 19; ++z)
    for (long y = 0; y < 5; ++y)
      for (long x = 0; x < 37; ++x) *slots.slot(x, y, z) = static_cast<int>(1 + x + 37 * (y + 5 * z));
  for (long z = 0; z < 19; ++z)
    for (long y = 0; y < 5; ++y)
      for (long x = 0; x < 37; ++x) ASSERT_EQ(*slots.slot(x, y, z), 1 + x + 37 * (y + 5 * z));
  EXPECT_EQ(slots.bricks_made(), all);

  BrickSlots<void*> sparse(1000, 1000, 1000);  // 1e9 cells: only what is asked about is made
  *sparse.slot(999, 0, 234) = &slots;
  EXPECT_EQ(sparse.bricks_made(), 1u);
  EXPECT_EQ(*sparse.slot(999, 0, 234), &slots);
  EXPECT_EQ(*sparse.slot(998, 1, 235), nullptr);  // the same brick, another cell
  EXPECT_EQ(sparse.bricks_made(), 1u);

  // More bricks than a 2 MB chunk holds (4096 of 64 8-byte slots): every cell still its own.
  BrickSlots<uint64_t> many(256, 256, 256);
  for (long z = 0; z < 256; z += 4)
    for (long y = 0; y < 256; y += 16)
      for (long x = 0; x < 256; x += 8)
        *many.slot(x, y, z) = static_cast<uint64_t>(1 + x + 256 * (y + 256 * z));
  EXPECT_EQ(many.bricks_made(), 64u * 16u * 32u);
  for (long z = 0; z < 256; z += 4)
    for (long y = 0; y < 256; y += 16)
      for (long x = 0; x < 256; x += 8) {
        ASSERT_EQ(*many.slot(x, y, z), static_cast<uint64_t>(1 + x + 256 * (y + 256 * z)));
        ASSERT_EQ(*many.slot(x + 1, y, z), 0u);
      }
}

TEST(BrickSlots, ThreadsAskingTheSameCellsShareTheirBricks) {
  BrickSlots<int> slots(64, 64, 64);
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&] {
      for (long z = 0; z < 64; ++z)
        for (long x = 0; x < 64; ++x) __atomic_fetch_add(slots.slot(x, z % 7, z), 1, __ATOMIC_RELAXED);
    });
  for (std::thread& th : pool) th.join();
  std::set<long> bricks;  // the 4-cell cubes asked about
  for (long z = 0; z < 64; ++z)
    for (long x = 0; x < 64; ++x) bricks.insert(((z / 4) * 2 + (z % 7) / 4) * 16 + x / 4);
  EXPECT_EQ(slots.bricks_made(), bricks.size());
  for (long z = 0; z < 64; ++z)
    for (long x = 0; x < 64; ++x) ASSERT_EQ(*slots.slot(x, z % 7, z), 4) << x << " " << z;
}

}  // namespace
}  // namespace weldtwin
