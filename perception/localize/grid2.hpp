// A 2D grid of square cells over a rectangle: the part's footprint, the table's heights near the part.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

namespace weldtwin {

struct Grid2 {
  double cell = 0.002;  ///< cell edge [m]
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  int nx = 0, ny = 0;
  std::vector<uint8_t> on;
  std::vector<float> value;  ///< per cell: the model's top height (footprint), the lowest point (table)

  /// The cells over [lo, hi], without `on` and `value` (for a grid whose cells hold something else).
  void shape(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double c) {
    cell = c;
    origin = lo;
    nx = static_cast<int>(std::ceil((hi.x() - lo.x()) / c)) + 1;
    ny = static_cast<int>(std::ceil((hi.y() - lo.y()) / c)) + 1;
  }
  size_t cells() const { return static_cast<size_t>(nx) * static_cast<size_t>(ny); }
  void reset(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double c) {
    shape(lo, hi, c);
    on.assign(cells(), 0);
    value.assign(on.size(), std::numeric_limits<float>::infinity());
  }
  /// The cell holding (x, y), or -1 outside the grid.
  long index(double x, double y) const {
    const long ix = static_cast<long>(std::floor((x - origin.x()) / cell)),
               iy = static_cast<long>(std::floor((y - origin.y()) / cell));
    if (ix < 0 || iy < 0 || ix >= nx || iy >= ny) return -1;
    return iy * nx + ix;
  }
  Eigen::Vector2d centre(long i) const {
    return origin +
           cell * Eigen::Vector2d(static_cast<double>(i % nx) + 0.5, static_cast<double>(i / nx) + 0.5);
  }
  /// Whether (x, y) falls in a cell that is on.
  bool covers(double x, double y) const {
    const long i = index(x, y);
    return i >= 0 && on[static_cast<size_t>(i)];
  }
};

/// The grid eroded by r cells: a cell stays on if every cell within r (a square) is on.
inline Grid2 eroded(const Grid2& g, int r) {
  Grid2 out = g;
  for (int y = 0; y < g.ny; ++y)
    for (int x = 0; x < g.nx; ++x) {
      bool all = g.on[static_cast<size_t>(y * g.nx + x)] != 0;
      for (int dy = -r; dy <= r && all; ++dy)
        for (int dx = -r; dx <= r && all; ++dx) {
          const int xx = x + dx, yy = y + dy;
          all = xx >= 0 && yy >= 0 && xx < g.nx && yy < g.ny && g.on[static_cast<size_t>(yy * g.nx + xx)];
        }
      out.on[static_cast<size_t>(y * g.nx + x)] = all;
    }
  return out;
}

}  // namespace weldtwin
