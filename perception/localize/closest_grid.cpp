#include "perception/localize/closest_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace weldtwin {
namespace {

constexpr double kRadiusSlack_m = 1e-9;  // rounding room on the candidate radius
constexpr double kTie = 1e-9;            // squared distances this close (relative) ...
constexpr double kTieFloor_m2 = 1e-20;   // ... or absolutely [m^2] are one distance

}  // namespace

ClosestGrid::ClosestGrid(const MeshRays& rays, const Vec3& lo, const Vec3& hi, const ClosestGridSetting& s)
    : rays_(rays), far_(s.far_m) {
  origin_ = lo - Vec3::Constant(s.margin_m);
  const Vec3 extent = hi - lo + Vec3::Constant(2 * s.margin_m);
  cell_ =
      std::max(s.cell_m, std::cbrt(extent.prod() / static_cast<double>(std::max<size_t>(1, s.max_cells))));
  half_diagonal_ = 0.5 * std::sqrt(3.0) * cell_;
  nx_ = static_cast<long>(extent.x() / cell_) + 1;
  ny_ = static_cast<long>(extent.y() / cell_) + 1;
  nz_ = static_cast<long>(extent.z() / cell_) + 1;
  slots_ = BrickSlots<Cell*>(nx_, ny_, nz_);
}

ClosestGrid::~ClosestGrid() = default;

const ClosestGrid::Cell* ClosestGrid::cell_at(long ix, long iy, long iz) const {
  Cell** slot = slots_.slot(ix, iy, iz);
  if (const Cell* known = __atomic_load_n(slot, __ATOMIC_ACQUIRE)) return known;
  // The nearest point of any point x of the cell is at most |x - c| + d(c) <= h + d(c) from x, so within
  // d(c) + 2h of the centre c: only faces that near can hold it.
  auto cell = std::make_unique<Cell>();
  const Vec3 c = origin_ + cell_ * Vec3(static_cast<double>(ix) + 0.5, static_cast<double>(iy) + 0.5,
                                        static_cast<double>(iz) + 0.5);
  cell->centre_distance_m = rays_.distance(c, far_);
  if (std::isfinite(cell->centre_distance_m)) {
    std::vector<unsigned> within;
    rays_.faces_within(c, cell->centre_distance_m + 2 * half_diagonal_ + kRadiusSlack_m, within);
    std::vector<std::pair<double, unsigned>> by_distance;
    for (unsigned f : within) by_distance.emplace_back((rays_.closest_on_face(c, f) - c).norm(), f);
    std::stable_sort(by_distance.begin(), by_distance.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [d, f] : by_distance) {
      cell->faces.push_back(f);
      cell->face_m.push_back(d);
    }
  }
  Cell* expected = nullptr;
  if (__atomic_compare_exchange_n(slot, &expected, cell.get(), false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE)) {
    const std::lock_guard<std::mutex> lock(made_mutex_);
    made_.push_back(std::move(cell));
    return made_.back().get();
  }
  return expected;  // another thread filled it first (with the same faces)
}

void ClosestGrid::put_cell(size_t slot, Cell cell) {
  using Slots = BrickSlots<Cell*>;
  Cell*& at = slots_.made_brick(slot / Slots::kBrickSlots)[slot % Slots::kBrickSlots];
  if (at) return;
  made_.push_back(std::make_unique<Cell>(std::move(cell)));
  at = made_.back().get();
}

bool ClosestGrid::closest(const Vec3& p, double max_m, Vec3& point, Vec3& face_normal) const {
  const Vec3 g = (p - origin_) / cell_;
  if (!(g.x() >= 0 && g.y() >= 0 && g.z() >= 0 && g.x() < static_cast<double>(nx_) &&
        g.y() < static_cast<double>(ny_) && g.z() < static_cast<double>(nz_)))
    return rays_.closest(p, max_m, point, face_normal);
  const Cell* cell = cell_at(static_cast<long>(g.x()), static_cast<long>(g.y()), static_cast<long>(g.z()));
  if (!std::isfinite(cell->centre_distance_m)) return rays_.closest(p, max_m, point, face_normal);
  if (cell->centre_distance_m - half_diagonal_ >= max_m) return false;  // nothing of the cell is that near
  double best = max_m * max_m;
  unsigned face = 0;
  bool found = false;
  // A face d from the centre is at least d - h from p: once that is beyond the best, so are the rest.
  for (size_t i = 0; i < cell->faces.size(); ++i) {
    const double reach = cell->face_m[i] - half_diagonal_;
    if (reach > 0 && reach * reach >= best * (1 + kTie)) break;
    const unsigned f = cell->faces[i];
    const Vec3 q = rays_.closest_on_face(p, f);
    const double d2 = (q - p).squaredNorm();
    // Faces meeting at an edge or a vertex are equally near a point beyond it (to rounding): the face the
    // point stands in front of most squarely gives the normal, whichever the order of the faces.
    const bool tie = found && std::abs(d2 - best) <= kTie * best + kTieFloor_m2;
    if (tie ? rays_.face_normal(f).dot(p - q) > rays_.face_normal(face).dot(p - point) : d2 < best) {
      best = std::min(best, d2);
      point = q;
      face = f;
      found = true;
    }
  }
  if (found) face_normal = rays_.face_normal(face);
  return found;
}

}  // namespace weldtwin
