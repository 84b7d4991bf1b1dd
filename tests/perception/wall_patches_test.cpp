// The walls' patches: the scan's points on a part's walls, judged patch by patch by their own spread. Noise
// alone leaves (almost) no patch off however large it is; a stretch of wall moved by a millimetre is off,
// found where it is and by how much; a patch off by less than the floor is not, however many points hold it.
#include <gtest/gtest.h>

#include <random>

#include "perception/localize/wall_patches.hpp"

namespace weldtwin {
namespace {

// Points on the wall x = 0 (facing -x) of a 300 mm long, 45 mm high part: `per_mm` along y, residuals
// N(0, sigma), plus `moved` for y within [moved_from, moved_to).
WallPatchFigure wall(double sigma, double per_mm, double moved, double moved_from, double moved_to,
                     uint64_t seed, const WallPatchSetting& setting = {}) {
  WallPatches patches(setting);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> z(0.005, 0.045);
  const int n = static_cast<int>(300 * per_mm);
  for (int i = 0; i < n; ++i) {
    const double y = 0.3 * i / n;
    const double r = noise(rng) + (y >= moved_from && y < moved_to ? moved : 0.0);
    patches.add(Vec3(0.0, y, z(rng)), Vec3(-1, 0, 0), r);
  }
  return patches.figure();
}

TEST(WallPatches, NoiseAloneLeavesNoPatchOffWhateverItsSize) {
  for (const double sigma : {0.0005, 0.0015, 0.004}) {
    for (uint64_t seed = 1; seed <= 5; ++seed) {
      const WallPatchFigure f = wall(sigma, 4.0, 0.0, 0.0, 0.0, seed);
      EXPECT_LT(f.off_share, 0.05) << sigma << " seed " << seed;
    }
  }
}

TEST(WallPatches, AStretchOfWallMovedByAMillimetreAndAHalfIsOffWhereItIs) {
  // 60 of the 300 mm moved 1.5 mm out of the wall, under 1.5 mm of noise: a fifth of the points off.
  const WallPatchFigure f = wall(0.0015, 10.0, 0.0015, 0.12, 0.18, 7);
  EXPECT_NEAR(f.off_share, 0.2, 0.05);
  EXPECT_GT(f.worst_at.y(), 0.12);
  EXPECT_LT(f.worst_at.y(), 0.18);
  EXPECT_NEAR(f.worst_offset_m, 0.0015, 0.0005);
  // Moved into the wall: the same share, the offset negative.
  const WallPatchFigure in = wall(0.0015, 10.0, -0.0015, 0.12, 0.18, 7);
  EXPECT_NEAR(in.off_share, 0.2, 0.05);
  EXPECT_LT(in.worst_offset_m, 0.0);
}

TEST(WallPatches, APatchOffByLessThanTheFloorIsNotOffHoweverManyPointsHoldIt) {
  // 0.3 mm, under the 0.5 mm floor, with so many points that it is 30 standard errors off.
  EXPECT_LT(wall(0.0005, 40.0, 0.0003, 0.0, 0.3, 3).off_share, 0.01);
  WallPatchSetting no_floor;
  no_floor.min_offset_m = 0.0;
  EXPECT_GT(wall(0.0005, 40.0, 0.0003, 0.0, 0.3, 3, no_floor).off_share, 0.95);
}

TEST(WallPatches, WallsFacingApartAreApartInOneCell) {
  // The two faces of a 3 mm wall in one cell, the scan 1 mm outside the one and 1 mm inside the other:
  // each face's patch is off (averaged together, they would cancel).
  WallPatches patches;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.0003);
  for (int i = 0; i < 50; ++i) {
    patches.add(Vec3(0.001, 0.002 + 0.0002 * i, 0.01), Vec3(-1, 0, 0), 0.001 + noise(rng));
    patches.add(Vec3(0.004, 0.002 + 0.0002 * i, 0.01), Vec3(1, 0, 0), -0.001 + noise(rng));
  }
  EXPECT_GT(patches.figure().off_share, 0.99);
}

}  // namespace
}  // namespace weldtwin
