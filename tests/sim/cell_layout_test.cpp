// Cell layouts: seeded draws are valid and varied, clamps touch the part, impossible layouts are refused.
#include "sim/cell_layout.hpp"

#include <gtest/gtest.h>

#include <set>

#include "core/error.hpp"
#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

const char* kCells[] = {"scenes/cells/default.yaml", "scenes/cells/round_on_plate.yaml",
                        "scenes/cells/tube_tee.yaml"};

TEST(CellLayout, SeededDrawsAreValidVariedAndReproducible) {
  for (const char* file : kCells) {
    const CellSpec cell = CellSpec::load(test::repo(file));
    const PartSpec part = PartSpec::load(cell.part_spec);
    double min_yaw = 10, max_yaw = -10;
    std::set<size_t> clamp_counts;
    for (uint64_t seed = 1; seed <= 200; ++seed) {
      const CellLayout a = make_layout(cell, part, seed);
      EXPECT_EQ(layout_problem(cell, part, a), "") << file << " seed " << seed;
      const double yaw = std::atan2(a.T_base_part.linear()(1, 0), a.T_base_part.linear()(0, 0));
      min_yaw = std::min(min_yaw, yaw);
      max_yaw = std::max(max_yaw, yaw);
      EXPECT_GE(a.clamps.size(), 2u);
      EXPECT_LE(a.clamps.size(), 4u);
      clamp_counts.insert(a.clamps.size());
      EXPECT_LE(a.clutter.size(), 3u);
      const CellLayout b = make_layout(cell, part, seed);
      EXPECT_TRUE(a.T_base_part.isApprox(b.T_base_part, 0.0));
      EXPECT_EQ(a.clamps.size(), b.clamps.size());
    }
    EXPECT_LT(min_yaw, -2.8) << file;  // yaw spans the whole circle
    EXPECT_GT(max_yaw, 2.8) << file;
    EXPECT_GE(clamp_counts.size(), 2u) << file;
  }
}

TEST(CellLayout, ClampPadsRestOnThePart) {
  for (const char* file : kCells) {
    for (uint64_t seed : {3u, 17u, 40u}) {
      test::Cell cell(file, seed);
      const MujocoWorld& w = *cell.world;
      for (size_t c = 0; c < cell.layout.clamps.size(); ++c) {
        // Straight down through the pad's contact point, ignoring the clamp itself: the part is right there.
        const Vec3 grip = cell.layout.clamps[c].T_base_clamp.translation();
        const Vec3 from = grip + Vec3(0, 0, 0.01), down(0, 0, -1);
        int geom = -1;
        const double t = mj_ray(w.model(), w.data(), from.data(), down.data(), nullptr, 1,
                                w.body("clamp" + std::to_string(c)), &geom);
        ASSERT_GE(geom, 0);
        EXPECT_EQ(w.geom_label(geom), Label::kPart) << file << " seed " << seed << " clamp " << c;
        EXPECT_NEAR(t, 0.01, 1e-6);
        // And the clamp's base block stands on the table top.
        const int base = mj_name2id(w.model(), mjOBJ_GEOM, ("clamp" + std::to_string(c) + "_base").c_str());
        EXPECT_NEAR(w.data()->geom_xpos[3 * base + 2] - w.model()->geom_size[3 * base + 2], 0.0, 1e-9);
      }
    }
  }
}

TEST(CellLayout, ImpossibleLayoutsAreRefused) {
  CellSpec cell = CellSpec::load(test::repo("scenes/cells/default.yaml"));
  const PartSpec part = PartSpec::load(cell.part_spec);
  auto why = [&](PartPose pose) {
    cell.part_pose = pose;
    try {
      make_layout(cell, part, std::nullopt);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(why({0.44, 0.06, 0.0, 0.4}), "");
  EXPECT_NE(why({0.161, 0.495, 0.0, deg2rad(45)}).find("off the table"),
            std::string::npos);  // within reach, over the edge
  EXPECT_NE(why({0.95, 0.0, 0.0, 0.0}).find("out of reach"), std::string::npos);
  EXPECT_NE(why({0.56, 0.0, 0.0, 0.0}).find("out of reach"), std::string::npos);  // seams beyond the reach
  EXPECT_NE(why({0.36, 0.0, 0.0, 0.0}).find("out of reach"), std::string::npos);  // too close to weld
  EXPECT_NE(why({0.44, 0.06, -0.002, 0.0}).find("intersects the table"), std::string::npos);
  EXPECT_NE(why({0.44, 0.06, 0.01, 0.0}).find("floats"), std::string::npos);
  EXPECT_NE(why({0.1, 0.55, 0.0, 0.0}).find("out of reach"), std::string::npos);  // bearing beyond 75 deg
  cell.part_pose = PartPose{0.44, 0.06, 0.0, 0.4};
  cell.clamp_sites = {7};
  EXPECT_THROW(make_layout(cell, part, std::nullopt), InputError);
}

}  // namespace
}  // namespace weldtwin
