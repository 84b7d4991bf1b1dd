#include "perception/localize/pose_search.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "perception/localize/stats.hpp"

namespace weldtwin {
namespace {

constexpr size_t kMinVoters = 20;     // fewer wall-high points: nothing part-like
constexpr size_t kMinNeighbours = 6;  // a normal from fewer points is not trusted
constexpr double kWallNormalZ = 0.5;  // a PCA normal with |n.z| below this is a wall's
constexpr int kYawKeyBins = 1024;     // yaw bins in a vote's key (at least 360 / vote_yaw_deg)
constexpr long long kXyKeyOffset = 100000;
constexpr long long kXyKeySpan = 200003;

long long vote_key(int ix, int iy, int iw) {
  return (static_cast<long long>(ix + kXyKeyOffset) * kXyKeySpan + (iy + kXyKeyOffset)) * kYawKeyBins + iw;
}

}  // namespace

PoseSearchResult search_poses(const ScenePoints& scene, PartModel& model, const PoseSearchSetting& s,
                              const std::optional<Iso3>& guess) {
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
  std::unordered_map<long long, int> votes;
  const int yaw_bins = static_cast<int>(std::round(360.0 / s.vote_yaw_deg));
  const size_t stride = std::max<size_t>(1, voters.size() / static_cast<size_t>(s.vote_points));
  std::vector<uint32_t> nidx;
  std::vector<double> nd2;
  for (size_t v = 0; v < voters.size(); v += stride) {
    const Vec3& q = scan[voters[v]];
    if (scene.tree.knn(q, static_cast<size_t>(s.normal_neighbours), nidx, nd2) < kMinNeighbours) continue;
    Vec3 mean = Vec3::Zero();
    for (uint32_t j : nidx) mean += scan[j];
    mean /= static_cast<double>(nidx.size());
    Mat3 C = Mat3::Zero();
    for (uint32_t j : nidx) C += (scan[j] - mean) * (scan[j] - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    const Vec3 nn = eig.eigenvectors().col(0);
    if (std::abs(nn.z()) > kWallNormalZ) continue;
    const double a = std::atan2(nn.y(), nn.x());
    const long bin = static_cast<long>(q.z() / model.height_bin_m);
    for (long hb = bin - 1; hb <= bin + 1; ++hb) {
      if (hb < 0 || hb >= static_cast<long>(model.walls_by_height.size())) continue;
      for (int k : model.walls_by_height[static_cast<size_t>(hb)]) {
        const Vec3& mp = model.pts[static_cast<size_t>(k)];
        const Vec3& mn = model.nrm[static_cast<size_t>(k)];
        const double b = std::atan2(mn.y(), mn.x());
        for (double flip : {0.0, kPi}) {
          double yaw = std::remainder(a - b + flip, 2 * kPi);
          if (yaw < 0) yaw += 2 * kPi;
          const double cy = std::cos(yaw), sy = std::sin(yaw);
          const double tx = q.x() - (cy * mp.x() - sy * mp.y()), ty = q.y() - (sy * mp.x() + cy * mp.y());
          const int iw = static_cast<int>(yaw / deg2rad(s.vote_yaw_deg)) % yaw_bins;
          ++votes[vote_key(static_cast<int>(std::floor(tx / s.vote_xy_m)),
                           static_cast<int>(std::floor(ty / s.vote_xy_m)), iw)];
        }
      }
    }
  }
  if (votes.empty()) {
    out.reason = "no part-like walls on the table";
    return out;
  }
  // Peaks: the best raw bins, ranked by the votes of their 3x3x3 neighbourhood, at least a bin apart.
  std::vector<std::pair<int, long long>> ranked;
  ranked.reserve(votes.size());
  for (const auto& [k, v] : votes) ranked.emplace_back(v, k);
  const size_t top = std::min<size_t>(ranked.size(), static_cast<size_t>(s.ranked_bins));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<long>(top), ranked.end(),
                    [](const auto& x, const auto& y) { return x.first > y.first; });
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
          const auto it = votes.find(vote_key(ix + dx, iy + dy, (iw + dw + yaw_bins) % yaw_bins));
          if (it != votes.end()) sum += it->second;
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
    for (const Hypothesis& o : hyps)
      close = close || (std::hypot(o.x - h.x, o.y - h.y) < s.distinct_xy_m &&
                        std::abs(std::remainder(o.yaw - h.yaw, 2 * kPi)) < deg2rad(s.distinct_yaw_deg));
    if (!close) hyps.push_back(h);
  }

  // A quick look at every peak (how many of a thin sample of points lie near the model there) decides
  // which are worth refining.
  const std::vector<ScanPoint> probe = thinned(scene.icp_points, static_cast<size_t>(s.quick_look_points));
  const double near2 = s.quick_look_m * s.quick_look_m;
  std::vector<std::pair<int, size_t>> quick;
  for (size_t i = 0; i < hyps.size(); ++i) {
    const Iso3 P0 = planar_pose(hyps[i].x, hyps[i].y, 0.0, hyps[i].yaw).inverse();
    int near = 0;
    for (const ScanPoint& sp : probe) {
      const Vec3 p = P0 * sp.raw;
      const int k = model.nearest(p);
      near += k >= 0 && (p - model.pts[static_cast<size_t>(k)]).squaredNorm() < near2;
    }
    quick.emplace_back(near, i);
  }
  std::stable_sort(quick.begin(), quick.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [near, i] : quick) out.hypotheses.push_back(hyps[i]);
  return out;
}

}  // namespace weldtwin
