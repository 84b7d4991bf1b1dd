// How likely a cloud without viewpoints is to hold points on the faces a pose matches them with. A scanner
// above the table samples a face more densely the more squarely it looks at it, and not at all where the
// part hides it; a sweep looks from a few places only. So each scan point is taken as drawn from the part's
// surface as seen from a mixture of directions (kViewDirections spread over the upper hemisphere, each
// sampling the faces it sees by the cosine of incidence), the mixture's weights fitted to the points
// (expectation-maximisation), plus a floor for what the model gets wrong. A pose that matches the scan of a
// wall's outer face with the inner face must have the scanner look steeply into the part, and then explain
// the rest of the points from there too: one pass seen from above fits its right pose, whichever faces it
// saw, not a fixed notion of which faces are "seen often" (the inside of a tube near its rim, seen steeply
// from above, is among the best seen faces of a pass over it).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

class MeshRays;
struct PartModel;

/// Rings at 15, 35, 55 and 75 deg elevation, 12 directions each, and straight up.
constexpr int kViewDirections = 49;

/// The directions (unit, pointing from the part towards the scanner) and the share of the upper
/// hemisphere's solid angle each stands for.
struct ViewDirections {
  std::array<Vec3, kViewDirections> d;
  std::array<double, kViewDirections> weight;
};
const ViewDirections& view_directions_above();

/// Bit i set: direction i faces the surface point (outward normal `n`) and leaves the part without hitting
/// it.
uint64_t view_mask(const MeshRays& rays, const Vec3& point, const Vec3& n);

/// The share of the model's samples each direction sees, weighted by the cosine of incidence (the
/// normaliser of each direction's sampling density): from PartModel::view_mask and the normals.
std::array<double, kViewDirections> view_totals(const std::vector<uint64_t>& masks,
                                                const std::vector<Vec3>& normals);

struct ViewPriorSetting {
  double weight = 1.0;  ///< the prior's nats are multiplied by this (0: no prior)
  /// A point's likelihood is (mixture density + floor) / (1 + floor), the density relative to the average
  /// sample's: a face the model takes as unseen may be seen after all; a point no face explains costs
  /// as much as one on such a face [share]
  double floor = 0.25;
  int max_iterations = 40;       ///< of expectation-maximisation
  double tolerance_nats = 0.01;  ///< ... until the total improves by less than this [nats]
};

/// The cost, in nats, of scan points matched with model samples `samples` (-1: a point on a face without a
/// sample near, taken as average; `unexplained` more points nothing explains), under the mixture of
/// directions that fits them best.
double view_prior_nats(const PartModel& model, const std::vector<int>& samples, int unexplained,
                       const ViewPriorSetting& setting);

}  // namespace weldtwin
