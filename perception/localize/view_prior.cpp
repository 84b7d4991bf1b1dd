#include "perception/localize/view_prior.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "perception/localize/part_model.hpp"
#include "perception/mesh_rays.hpp"

namespace weldtwin {
namespace {

constexpr double kRingElevationsDeg[] = {15.0, 35.0, 55.0, 75.0};
constexpr int kRingDirections = 12;
constexpr double kRingSpacingDeg = 20.0;  // each ring stands for the band this wide around its elevation
constexpr double kCapFromDeg = 85.0;      // ... and straight up for the cap above this

// What one point nothing explains costs: as one on a face the model takes as unseen [nats].
double unexplained_view_nats(const ViewPriorSetting& s) {
  return -s.weight * std::log(s.floor / (1.0 + s.floor));
}

}  // namespace

const ViewDirections& view_directions_above() {
  static const ViewDirections dirs = [] {
    ViewDirections out;
    int i = 0;
    const double band = deg2rad(kRingSpacingDeg);
    for (double e_deg : kRingElevationsDeg) {
      const double e = deg2rad(e_deg);
      for (int a = 0; a < kRingDirections; ++a, ++i) {
        const double az = 2 * kPi * a / kRingDirections;
        out.d[static_cast<size_t>(i)] =
            Vec3(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az), std::sin(e));
        out.weight[static_cast<size_t>(i)] = std::cos(e) * band / kRingDirections;
      }
    }
    out.d[static_cast<size_t>(i)] = Vec3::UnitZ();
    out.weight[static_cast<size_t>(i)] = 1.0 - std::sin(deg2rad(kCapFromDeg));
    double sum = 0.0;
    for (double w : out.weight) sum += w;
    for (double& w : out.weight) w /= sum;
    return out;
  }();
  return dirs;
}

uint64_t view_mask(const MeshRays& rays, const Vec3& point, const Vec3& n) {
  const ViewDirections& v = view_directions_above();
  uint64_t mask = 0;
  for (int i = 0; i < kViewDirections; ++i) {
    const Vec3& d = v.d[static_cast<size_t>(i)];
    if (d.dot(n) > 0.0 && !std::isfinite(rays.hit(point, d))) mask |= uint64_t{1} << i;
  }
  return mask;
}

std::array<double, kViewDirections> view_totals(const std::vector<uint64_t>& masks,
                                                const std::vector<Vec3>& normals) {
  const ViewDirections& v = view_directions_above();
  std::array<double, kViewDirections> total{};
  for (size_t k = 0; k < masks.size(); ++k)
    for (int i = 0; i < kViewDirections; ++i)
      if (masks[k] >> i & 1) total[static_cast<size_t>(i)] += v.d[static_cast<size_t>(i)].dot(normals[k]);
  for (double& t : total) t /= std::max<size_t>(1, masks.size());
  return total;
}

double view_prior_nats(const PartModel& m, const std::vector<int>& samples, int unexplained,
                       const ViewPriorSetting& s) {
  const ViewDirections& v = view_directions_above();
  // Each matched point's density under each direction, relative to the average sample's. It depends on
  // the sample's mask and normal only, so points on one face seen from the same directions share a row
  // (normals within kSameNormal of each other count as one): tens to hundreds of rows, not thousands.
  constexpr double kSameNormal = 0.02;
  std::vector<std::array<float, kViewDirections>> g;
  std::vector<double> count;
  std::map<std::tuple<uint64_t, long, long, long>, size_t> row_of;
  for (int k : samples) {
    if (k < 0) continue;
    const uint64_t mask = m.view_mask[static_cast<size_t>(k)];
    const Vec3& n = m.nrm[static_cast<size_t>(k)];
    const auto [it, added] =
        row_of.try_emplace({mask, std::lround(n.x() / kSameNormal), std::lround(n.y() / kSameNormal),
                            std::lround(n.z() / kSameNormal)},
                           g.size());
    if (!added) {
      count[it->second] += 1.0;
      continue;
    }
    std::array<float, kViewDirections> row{};
    for (int i = 0; i < kViewDirections; ++i) {
      const double total = m.view_total[static_cast<size_t>(i)];
      if ((mask >> i & 1) && total > 0.0)
        row[static_cast<size_t>(i)] = static_cast<float>(v.d[static_cast<size_t>(i)].dot(n) / total);
    }
    g.push_back(row);
    count.push_back(1.0);
  }
  // The mixture's weights, from the directions' solid angles, fitted by expectation-maximisation with the
  // floor's share held fixed.
  std::array<double, kViewDirections> pi = v.weight;
  double before = -1e300, nats = 0.0;
  std::vector<double> q(g.size());
  for (int it = 0; it < s.max_iterations; ++it) {
    double loglik = 0.0;
    for (size_t j = 0; j < g.size(); ++j) {
      double sum = 0.0;
      for (int i = 0; i < kViewDirections; ++i)
        sum += pi[static_cast<size_t>(i)] * g[j][static_cast<size_t>(i)];
      q[j] = sum + s.floor;
      loglik += count[j] * std::log(q[j] / (1.0 + s.floor));
    }
    nats = -loglik;
    if (loglik - before < s.tolerance_nats) break;
    before = loglik;
    std::array<double, kViewDirections> next{};
    double all = 0.0;
    for (size_t j = 0; j < g.size(); ++j)
      for (int i = 0; i < kViewDirections; ++i) {
        const double r = count[j] * pi[static_cast<size_t>(i)] * g[j][static_cast<size_t>(i)] / q[j];
        next[static_cast<size_t>(i)] += r;
        all += r;
      }
    if (!(all > 0.0)) break;
    for (int i = 0; i < kViewDirections; ++i) pi[static_cast<size_t>(i)] = next[static_cast<size_t>(i)] / all;
  }
  // A point on a face with no sample near is taken as an average one (density 1): it costs nothing.
  return s.weight * nats + unexplained * unexplained_view_nats(s);
}

}  // namespace weldtwin
