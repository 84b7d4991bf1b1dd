// Offscreen pictures: the same state and view give the same pixels, and the pictures show a scene.
#include "sim/renderer.hpp"

#include <gtest/gtest.h>
#include <png.h>

#include <cstring>

#include "tests/test_support.hpp"

namespace weldtwin {
namespace {

TEST(Renderer, DeterministicNonBlankAndAValidPng) {
  const test::Cell cell;
  OffscreenRenderer renderer(cell.world->model(), 320, 240);
  DataPtr d = cell.world->make_data();
  cell.world->set_joints(d.get(), JointVector::Zero());
  const Image a = renderer.render(d.get(), View{"overview"});
  const Image b = renderer.render(d.get(), View{"overview"});
  ASSERT_EQ(a.rgb.size(), 320u * 240u * 3u);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_GT(a.spread(), 10.0);
  // Another view and an overlay change the picture.
  const Image side = renderer.render(d.get(), View{"side"});
  EXPECT_NE(side.rgb, a.rgb);
  Overlay o;
  o.segments.emplace_back(Vec3(0.3, -0.2, 0.05), Vec3(0.5, 0.2, 0.05));
  o.segment_width_m = 0.01;
  EXPECT_NE(renderer.render(d.get(), View{"overview"}, o).rgb, a.rgb);
  // The PNG decodes (libpng) to the same pixels.
  const std::vector<uint8_t> bytes = a.png();
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_memory(&img, bytes.data(), bytes.size()));
  img.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> back(PNG_IMAGE_SIZE(img));
  ASSERT_TRUE(png_image_finish_read(&img, nullptr, back.data(), 0, nullptr));
  EXPECT_EQ(img.width, 320u);
  EXPECT_EQ(back, a.rgb);
}

}  // namespace
}  // namespace weldtwin
