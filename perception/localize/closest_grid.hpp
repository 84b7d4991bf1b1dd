// The part's surface point nearest a point, as MeshRays::closest answers it, from a lazily filled grid of
// candidate faces. The surface fit asks about the same few thousand places hundreds of thousands of times (a
// real scan: 640 k questions in 14 k cells of 2 mm); each cell keeps the faces that can hold the nearest
// point of any point inside it, so that a question is a handful of point-triangle distances instead of a walk
// of Embree's tree. The answers are the same as the mesh's (exact, not interpolated): the faces are chosen by
// a bound, not by sampling.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "core/geometry.hpp"
#include "perception/localize/brick_slots.hpp"
#include "perception/mesh_rays.hpp"

namespace weldtwin {

struct ClosestGridSetting {
  double cell_m = 0.002;       ///< grid cell [m]
  double margin_m = 0.02;      ///< the grid reaches this far beyond the part's box [m]
  double far_m = 0.02;         ///< a cell farther than this from the surface asks the mesh itself [m]
  size_t max_cells = 1 << 24;  ///< a larger part gets larger cells (the same answers, more faces per cell)
};

class ClosestGrid {
 public:
  /// A grid over the box lo..hi (grown by the margin) of the surface `rays` holds; `rays` must outlive it.
  ClosestGrid(const MeshRays& rays, const Vec3& lo, const Vec3& hi, const ClosestGridSetting& setting);
  ~ClosestGrid();
  ClosestGrid(const ClosestGrid&) = delete;
  ClosestGrid& operator=(const ClosestGrid&) = delete;

  /// As MeshRays::closest: the surface point nearest `p` within `max_m` (false if none), and the outward
  /// normal of its face; where faces meet at the nearest point (an edge, a vertex), the normal of the face
  /// `p` stands in front of most squarely (Embree's point query takes whichever it meets first). Safe to
  /// call from several threads.
  bool closest(const Vec3& p, double max_m, Vec3& point, Vec3& face_normal) const;
  double cell_m() const { return cell_; }

  struct Cell {
    double centre_distance_m = 0.0;  ///< from the cell's centre to the surface
    std::vector<unsigned> faces;     ///< every face that can be nearest to a point of the cell, ...
    std::vector<double> face_m;      ///< ... nearest the centre first, and how far from it [m]
  };
  /// The cells filled so far, as fn(slot, cell) (slot < slots(): which cell of the grid it is), for keeping
  /// them between runs (part_model_file.hpp). Not while another thread asks the grid.
  template <class Fn>
  void for_each_cell(Fn fn) const {
    using Slots = BrickSlots<Cell*>;
    for (size_t b = 0; b < slots_.brick_capacity(); ++b)
      if (Cell* const* brick = slots_.brick(b))
        for (size_t i = 0; i < Slots::kBrickSlots; ++i)
          if (brick[i]) fn(b * Slots::kBrickSlots + i, *brick[i]);
  }
  size_t slots() const { return slots_.brick_capacity() * BrickSlots<Cell*>::kBrickSlots; }
  size_t cells_made() const {
    const std::lock_guard<std::mutex> lock(made_mutex_);
    return made_.size();
  }
  /// Puts in a cell an earlier run filled (slot < slots(); its faces those cell_at finds there), unless the
  /// cell is filled already. Not while another thread asks the grid.
  void put_cell(size_t slot, Cell cell);

 private:
  const Cell* cell_at(long ix, long iy, long iz) const;

  const MeshRays& rays_;
  Vec3 origin_ = Vec3::Zero();
  double cell_ = 0.0, half_diagonal_ = 0.0, far_ = 0.0;
  long nx_ = 0, ny_ = 0, nz_ = 0;
  mutable BrickSlots<Cell*> slots_;  ///< null until asked (only the bricks of cells asked about are made)
  mutable std::mutex made_mutex_;
  mutable std::vector<std::unique_ptr<Cell>> made_;  ///< the cells filled so far (they own their memory)
};

}  // namespace weldtwin
