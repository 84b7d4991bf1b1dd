#include "sim/weldability_picture.hpp"

#include <algorithm>
#include <cmath>

namespace weldtwin {

MapMark footprint_mark(const PartSpec& part, double x_m, double y_m, double yaw_rad,
                       std::array<uint8_t, 3> rgb) {
  MapMark mark;
  mark.rgb = rgb;
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  for (const Eigen::Vector2d& p : part.footprint)
    mark.outline_base.emplace_back(x_m + c * p.x() - s * p.y(), y_m + s * p.x() + c * p.y());
  return mark;
}

Image weldability_picture(const WeldabilityMap& map, const std::vector<MapMark>& marks, int pixels_per_cm) {
  // Picture up = +x (away from the robot), picture right = -y: the table as seen from above, standing
  // behind the robot.
  const double px_per_m = 100.0 * pixels_per_cm;
  const double x_min = map.x0_m - 0.5 * map.grid_m, y_min = map.y0_m - 0.5 * map.grid_m;
  const double x_max = x_min + static_cast<double>(map.nx) * map.grid_m;
  const double y_max = y_min + static_cast<double>(map.ny) * map.grid_m;
  Image img;
  img.width = static_cast<int>(std::ceil((y_max - y_min) * px_per_m));
  img.height = static_cast<int>(std::ceil((x_max - x_min) * px_per_m));
  img.rgb.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 255);
  const auto put = [&](int col, int row, std::array<uint8_t, 3> rgb) {
    if (col < 0 || row < 0 || col >= img.width || row >= img.height) return;
    uint8_t* p = img.rgb.data() +
                 (static_cast<size_t>(row) * static_cast<size_t>(img.width) + static_cast<size_t>(col)) * 3;
    p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2];
  };
  const auto pixel_of = [&](double x, double y) {
    return Eigen::Vector2d((y_max - y) * px_per_m, (x_max - x) * px_per_m);  // (col, row)
  };

  // Each position's colour, then every pixel takes its nearest position's.
  std::vector<std::array<uint8_t, 3>> colour(map.nx * map.ny);
  for (size_t ix = 0; ix < map.nx; ++ix)
    for (size_t iy = 0; iy < map.ny; ++iy) {
      size_t welds = 0, roomy = 0, collides = 0;
      for (size_t iyaw = 0; iyaw < map.nyaw; ++iyaw) {
        const MapPlacement& p = map.at(ix, iy, iyaw);
        welds += p.kind == PlacementKind::kWelds;
        roomy += p.kind != PlacementKind::kNoRoom;
        collides += p.kind == PlacementKind::kCollides;
      }
      std::array<uint8_t, 3> rgb{205, 205, 205};  // no room at any yaw
      if (welds > 0) {
        const double share = static_cast<double>(welds) / static_cast<double>(roomy);
        rgb = {static_cast<uint8_t>(200 - 170 * share), static_cast<uint8_t>(235 - 85 * share),
               static_cast<uint8_t>(200 - 170 * share)};
      } else if (roomy > 0) {
        rgb = 2 * collides >= roomy ? std::array<uint8_t, 3>{215, 70, 60}
                                    : std::array<uint8_t, 3>{240, 165, 60};
      }
      colour[ix * map.ny + iy] = rgb;
    }
  for (int row = 0; row < img.height; ++row)
    for (int col = 0; col < img.width; ++col) {
      const double x = x_max - (row + 0.5) / px_per_m, y = y_max - (col + 0.5) / px_per_m;
      const long ix = std::lround((x - map.x0_m) / map.grid_m), iy = std::lround((y - map.y0_m) / map.grid_m);
      if (ix < 0 || iy < 0 || ix >= static_cast<long>(map.nx) || iy >= static_cast<long>(map.ny)) continue;
      put(col, row, colour[static_cast<size_t>(ix) * map.ny + static_cast<size_t>(iy)]);
    }

  // The robot's base: a black disc at the base axis.
  const Eigen::Vector2d base = pixel_of(0.0, 0.0);
  const int r = static_cast<int>(0.06 * px_per_m);
  for (int dr = -r; dr <= r; ++dr)
    for (int dc = -r; dc <= r; ++dc)
      if (dr * dr + dc * dc <= r * r)
        put(static_cast<int>(base.x()) + dc, static_cast<int>(base.y()) + dr, {20, 20, 20});

  // Marks: outlines three pixels wide, and a dot at the first corner (the part's orientation).
  for (const MapMark& m : marks) {
    for (size_t k = 0; k < m.outline_base.size(); ++k) {
      const Eigen::Vector2d a = pixel_of(m.outline_base[k].x(), m.outline_base[k].y());
      const Eigen::Vector2d b = pixel_of(m.outline_base[(k + 1) % m.outline_base.size()].x(),
                                         m.outline_base[(k + 1) % m.outline_base.size()].y());
      const int steps = static_cast<int>(std::ceil((b - a).norm())) + 1;
      for (int i = 0; i <= steps; ++i) {
        const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / steps);
        for (int dr = -1; dr <= 1; ++dr)
          for (int dc = -1; dc <= 1; ++dc)
            put(static_cast<int>(p.x()) + dc, static_cast<int>(p.y()) + dr, m.rgb);
      }
    }
    if (!m.outline_base.empty()) {
      const Eigen::Vector2d p = pixel_of(m.outline_base.front().x(), m.outline_base.front().y());
      for (int dr = -4; dr <= 4; ++dr)
        for (int dc = -4; dc <= 4; ++dc)
          put(static_cast<int>(p.x()) + dc, static_cast<int>(p.y()) + dr, m.rgb);
    }
  }
  return img;
}

}  // namespace weldtwin
