#include "perception/localize/pose_search.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/parallel_for.hpp"
#include "perception/localize/stats.hpp"

namespace weldtwin {
namespace {

constexpr size_t kMinVoters = 20;     // fewer wall-high points: nothing part-like
constexpr size_t kMinNeighbours = 6;  // a normal from fewer points is not trusted
constexpr double kWallNormalZ = 0.5;  // a PCA normal with |n.z| below this is a wall's
constexpr int kYawKeyBins = 1024;     // yaw bins in a vote's key (at least 360 / vote_yaw_deg)
constexpr long long kXyKeyOffset = 100000;
constexpr long long kXyKeySpan = 200003;
constexpr size_t kVoteChunks = 32;  // the voters in this many runs, taken by the workers as they finish one

long long vote_key(int ix, int iy, int iw) {
  return (static_cast<long long>(ix + kXyKeyOffset) * kXyKeySpan + (iy + kXyKeyOffset)) * kYawKeyBins + iw;
}

// Vote counts by key: open addressing in one flat table (a vote is a probe or two in memory, not a node of a
// hash map), grown at half full.
class VoteCounts {
 public:
  void add(long long key, int count = 1) {
    if (2 * (used_ + 1) > slots_.size()) grow();
    size_t i = slot_of(key);
    while (slots_[i].count != 0 && slots_[i].key != key) i = (i + 1) & (slots_.size() - 1);
    if (slots_[i].count == 0) {
      slots_[i].key = key;
      ++used_;
    }
    slots_[i].count += count;
  }
  /// Another table's votes added to these.
  void add_all(const VoteCounts& other) {
    for (const Slot& e : other.slots_)
      if (e.count != 0) add(e.key, e.count);
  }
  int get(long long key) const {
    if (slots_.empty()) return 0;
    for (size_t i = slot_of(key);; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i].count == 0) return 0;
      if (slots_[i].key == key) return slots_[i].count;
    }
  }
  bool empty() const { return used_ == 0; }
  /// Every (count, key), in no particular order.
  std::vector<std::pair<int, long long>> entries() const {
    std::vector<std::pair<int, long long>> out;
    out.reserve(used_);
    for (const Slot& e : slots_)
      if (e.count != 0) out.emplace_back(e.count, e.key);
    return out;
  }

 private:
  struct Slot {
    long long key = 0;
    int count = 0;
  };
  size_t slot_of(long long key) const {
    return static_cast<size_t>((static_cast<unsigned long long>(key) * 0x9E3779B97F4A7C15ull) >> 20) &
           (slots_.size() - 1);
  }
  void grow() {
    std::vector<Slot> old = std::move(slots_);
    slots_.assign(std::max<size_t>(kInitialSlots, 2 * old.size()), Slot{});
    used_ = 0;
    for (const Slot& e : old)
      if (e.count != 0) {
        size_t i = slot_of(e.key);
        while (slots_[i].count != 0) i = (i + 1) & (slots_.size() - 1);
        slots_[i] = e;
        ++used_;
      }
  }
  static constexpr size_t kInitialSlots = 1 << 16;
  std::vector<Slot> slots_;
  size_t used_ = 0;
};

}  // namespace

PoseSearchResult search_poses(const ScenePoints& scene, PartModel& model, const PoseSearchSetting& s,
                              const std::optional<Iso3>& guess, int threads) {
  PoseSearchResult out;
  const std::vector<Vec3>& scan = scene.objects;
  const double height_cut = scene.limits.height_cut_m;
  // Hough voting over (x, y, yaw): a scan wall point at height z with horizontal normal direction a, matched
  // with a model wall point at the same height with normal direction b, votes for yaw = a - b (and a - b +
  // pi, for PCA normals have no sign) and the translation that puts the model point on the scan point.
  std::vector<size_t> voters;
  for (size_t i = 0; i < scan.size(); ++i)
    if (scan[i].z() >= height_cut) voters.push_back(i);
  if (voters.size() < kMinVoters) {
    out.reason = "nothing part-like stands on the table";
    return out;
  }
  // The direction of every model wall sample's normal, once.
  std::vector<std::vector<double>> wall_angle(model.walls_by_height.size());
  for (size_t hb = 0; hb < model.walls_by_height.size(); ++hb)
    for (int k : model.walls_by_height[hb]) {
      const Vec3& mn = model.nrm[static_cast<size_t>(k)];
      wall_angle[hb].push_back(std::atan2(mn.y(), mn.x()));
    }
  const int yaw_bins = static_cast<int>(std::round(360.0 / s.vote_yaw_deg));
  const size_t stride = std::max<size_t>(1, voters.size() / static_cast<size_t>(s.vote_points));
  // The votes of one scan point.
  auto cast_votes = [&](size_t v, VoteCounts& table, std::vector<uint32_t>& nidx, std::vector<double>& nd2) {
    const Vec3& q = scan[voters[v]];
    if (scene.tree.knn(q, static_cast<size_t>(s.normal_neighbours), nidx, nd2) < kMinNeighbours) return;
    Vec3 mean = Vec3::Zero();
    for (uint32_t j : nidx) mean += scan[j];
    mean /= static_cast<double>(nidx.size());
    Mat3 C = Mat3::Zero();
    for (uint32_t j : nidx) C += (scan[j] - mean) * (scan[j] - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    const Vec3 nn = eig.eigenvectors().col(0);
    if (std::abs(nn.z()) > kWallNormalZ) return;
    const double a = std::atan2(nn.y(), nn.x());
    const long bin = static_cast<long>(q.z() / model.height_bin_m);
    for (long hb = bin - 1; hb <= bin + 1; ++hb) {
      if (hb < 0 || hb >= static_cast<long>(model.walls_by_height.size())) continue;
      const std::vector<int>& walls = model.walls_by_height[static_cast<size_t>(hb)];
      for (size_t j = 0; j < walls.size(); ++j) {
        const Vec3& mp = model.pts[static_cast<size_t>(walls[j])];
        double yaw = std::remainder(a - wall_angle[static_cast<size_t>(hb)][j], 2 * kPi);
        if (yaw < 0) yaw += 2 * kPi;
        double cy = std::cos(yaw), sy = std::sin(yaw);
        for (int flip = 0; flip < 2; ++flip) {  // the turn by pi: the same point, the other normal sign
          if (flip) {
            yaw = yaw < kPi ? yaw + kPi : yaw - kPi;
            cy = -cy;
            sy = -sy;
          }
          const double tx = q.x() - (cy * mp.x() - sy * mp.y()), ty = q.y() - (sy * mp.x() + cy * mp.y());
          const int iw = static_cast<int>(yaw / deg2rad(s.vote_yaw_deg)) % yaw_bins;
          table.add(vote_key(static_cast<int>(std::floor(tx / s.vote_xy_m)),
                             static_cast<int>(std::floor(ty / s.vote_xy_m)), iw));
        }
      }
    }
  };
  // Cast on every core, a table per worker, then added up: a count does not depend on the order its votes
  // came in, and the peaks are ranked by count and key alone.
  const size_t casting = (voters.size() + stride - 1) / stride;
  const size_t chunks = std::min(casting, kVoteChunks);
  std::vector<VoteCounts> tables(parallel_workers(chunks, threads));
  std::atomic<size_t> next_table{0};
  parallel_for_with(
      chunks, threads, [&] { return &tables[next_table++]; },
      [&](VoteCounts* table, size_t chunk) {
        std::vector<uint32_t> nidx;
        std::vector<double> nd2;
        for (size_t c = chunk * casting / chunks; c < (chunk + 1) * casting / chunks; ++c)
          cast_votes(c * stride, *table, nidx, nd2);
      });
  VoteCounts& votes = tables.front();
  for (size_t t = 1; t < tables.size(); ++t) votes.add_all(tables[t]);
  if (votes.empty()) {
    out.reason = "no part-like walls on the table";
    return out;
  }
  // Peaks: the best raw bins, ranked by the votes of their 3x3x3 neighbourhood, at least a bin apart.
  // (Of bins with as many votes, the lower key first: the same peaks whatever the table's order.)
  std::vector<std::pair<int, long long>> ranked = votes.entries();
  const size_t top = std::min<size_t>(ranked.size(), static_cast<size_t>(s.ranked_bins));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<long>(top), ranked.end(),
                    [](const auto& x, const auto& y) {
                      return x.first > y.first || (x.first == y.first && x.second < y.second);
                    });
  std::vector<Hypothesis> peaks;
  for (size_t r = 0; r < top; ++r) {
    const long long k = ranked[r].second;
    const int iw = static_cast<int>(k % kYawKeyBins);
    const long long rk = k / kYawKeyBins;
    const int iy = static_cast<int>(rk % kXyKeySpan) - kXyKeyOffset,
              ix = static_cast<int>(rk / kXyKeySpan) - kXyKeyOffset;
    int sum = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dw = -1; dw <= 1; ++dw) {
          sum += votes.get(vote_key(ix + dx, iy + dy, (iw + dw + yaw_bins) % yaw_bins));
        }
    peaks.push_back(
        {(ix + 0.5) * s.vote_xy_m, (iy + 0.5) * s.vote_xy_m, (iw + 0.5) * deg2rad(s.vote_yaw_deg), sum});
  }
  std::stable_sort(peaks.begin(), peaks.end(),
                   [](const auto& a, const auto& b) { return a.votes > b.votes; });
  if (guess) {
    const Iso3& T = *guess;
    peaks.insert(peaks.begin(), {T.translation().x(), T.translation().y(),
                                 std::atan2(T.linear()(1, 0), T.linear()(0, 0)), 1 << 30});
  }
  std::vector<Hypothesis> hyps;
  for (const Hypothesis& h : peaks) {
    if (static_cast<int>(hyps.size()) >= s.hypotheses) break;
    bool close = false;
    int here = 0;  // peaks already taken at this place, whatever their turn
    for (const Hypothesis& o : hyps) {
      const bool same_place = std::hypot(o.x - h.x, o.y - h.y) < s.distinct_xy_m;
      here += same_place;
      close = close ||
              (same_place && std::abs(std::remainder(o.yaw - h.yaw, 2 * kPi)) < deg2rad(s.distinct_yaw_deg));
    }
    if (!close && here < s.max_turns_per_place) hyps.push_back(h);
  }

  // A quick look at every peak (how many of a thin sample of points lie near the model there) decides
  // which are worth refining.
  const std::vector<ScanPoint> probe = thinned(scene.icp_points, static_cast<size_t>(s.quick_look_points));
  const double near2 = s.quick_look_m * s.quick_look_m;
  std::vector<std::pair<int, size_t>> quick(hyps.size());
  parallel_for(hyps.size(), threads, [&](size_t i) {
    const Iso3 P0 = planar_pose(hyps[i].x, hyps[i].y, 0.0, hyps[i].yaw).inverse();
    int near = 0;
    for (const ScanPoint& sp : probe) {
      const Vec3 p = P0 * sp.raw;
      const int k = model.nearest(p);
      near += k >= 0 && (p - model.pts[static_cast<size_t>(k)]).squaredNorm() < near2;
    }
    quick[i] = {near, i};
  });
  std::stable_sort(quick.begin(), quick.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [near, i] : quick) out.hypotheses.push_back(hyps[i]);
  return out;
}

}  // namespace weldtwin
