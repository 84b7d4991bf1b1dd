// Offscreen pictures of the twin through OSMesa (no display, no GPU): MuJoCo's own renderer drawing the cell,
// plus overlays — LiDAR points coloured by label, the part's model at an estimated pose, a torch path.
// Deterministic: the same state and view give the same pixels.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "core/geometry.hpp"

namespace weldtwin {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  ///< top row first
  /// PNG file bytes (libpng).
  std::vector<uint8_t> png() const;
  void write_png(const std::string& path) const;
  /// Standard deviation of the pixel values (0 for a blank picture).
  double spread() const;
};

using Rgba = std::array<float, 4>;

struct Overlay {
  std::vector<Vec3> points;  ///< base frame
  std::vector<Rgba> point_rgba;
  double point_size_m = 0.0015;
  std::vector<std::pair<Vec3, Vec3>> segments;  ///< drawn as thin capsules
  Rgba segment_rgba{1.0f, 0.85f, 0.1f, 1.0f};
  double segment_width_m = 0.0012;
  int ghost_mesh = -1;  ///< a model mesh id drawn again at ghost_pose (e.g. the part where it was found)
  Iso3 ghost_pose = Iso3::Identity();
  Rgba ghost_rgba{0.2f, 0.5f, 1.0f, 0.45f};
  float part_alpha = 1.0f;         ///< transparency of the real part (geoms named "part")
  std::vector<uint8_t> hide_geom;  ///< by model geom id: non-zero = not drawn
};

/// A camera: a named camera of the model, or a free one looking at `lookat`.
struct View {
  std::string camera;  ///< "" for the free camera
  Vec3 lookat = Vec3::Zero();
  double distance_m = 1.5, azimuth_deg = 135.0, elevation_deg = -30.0;
};

class OffscreenRenderer {
 public:
  /// width x height at most the model's <visual><global offwidth offheight>. Throws std::runtime_error when
  /// no OSMesa context can be made.
  OffscreenRenderer(const mjModel* model, int width, int height);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  /// The state in `data` (after kinematics) seen from `view`.
  Image render(mjData* data, const View& view, const Overlay& overlay = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace weldtwin
