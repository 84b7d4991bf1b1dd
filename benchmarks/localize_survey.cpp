// Randomized localization benchmark on twin scans with ground truth: seeded cells per part (any yaw, 2-4
// clamps, clutter, default LiDAR noise), each swept and localized by ours and by the paper's pipeline on the
// same scan. Success = found, every seam point within the part's weld tolerance (1 mm unless its spec says
// otherwise) of the true seams and rotation within 0.5 deg.
// Also counts false accepts: every scan with its part's points removed, and every other part's mesh sought
// in it, must be refused.
//   localize_survey [--layouts N] [--seed S] [--jobs J] [--cache DIR] [--csv FILE] [--no-paper] CELL.yaml...
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>

#include "benchmarks/real_scan_check.hpp"
#include "core/cell_robot.hpp"
#include "core/cloud_io.hpp"
#include "core/error.hpp"
#include "core/parallel_for.hpp"
#include "perception/localizer.hpp"
#include "perception/paper_localizer.hpp"
#include "perception/pose_error.hpp"
#include "perception/scan_assembly.hpp"
#include "pipeline/weld_pipeline.hpp"
#include "sim/part_deviation.hpp"
#include "sim/sweep_sim.hpp"
#include "sim/twin_calibration.hpp"

using namespace weldtwin;

namespace {

struct Scan {
  std::vector<Vec3> points;
  std::vector<uint8_t> labels;
  std::vector<Vec3> viewpoints;  ///< the sensor's position for each point
  Iso3 truth = Iso3::Identity();
};

// Cache: point count, T (16 doubles), then float xyz per point, a label per point, float xyz of the sensor
// per point. Only for re-running quickly.
bool read_cache(const std::string& file, Scan& scan) {
  std::ifstream in(file, std::ios::binary);
  uint64_t n = 0;
  if (!in.read(reinterpret_cast<char*>(&n), sizeof n)) return false;
  double T[16];
  in.read(reinterpret_cast<char*>(T), sizeof T);
  for (int i = 0; i < 16; ++i) scan.truth.matrix()(i / 4, i % 4) = T[i];
  std::vector<float> xyz(3 * n);
  scan.labels.resize(n);
  in.read(reinterpret_cast<char*>(xyz.data()), static_cast<std::streamsize>(xyz.size() * sizeof(float)));
  in.read(reinterpret_cast<char*>(scan.labels.data()), static_cast<std::streamsize>(n));
  std::vector<float> vp(3 * n);
  in.read(reinterpret_cast<char*>(vp.data()), static_cast<std::streamsize>(vp.size() * sizeof(float)));
  if (!in) return false;
  scan.points.resize(n);
  scan.viewpoints.resize(n);
  for (size_t i = 0; i < n; ++i) {
    scan.points[i] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    scan.viewpoints[i] = Vec3(vp[3 * i], vp[3 * i + 1], vp[3 * i + 2]);
  }
  return true;
}

// The scan as the cache (and a float PCD) holds it: a first run answers what a re-run from the cache does.
void round_as_cached(Scan& scan) {
  for (std::vector<Vec3>* v : {&scan.points, &scan.viewpoints})
    for (Vec3& p : *v) p = p.cast<float>().cast<double>();
}

void write_cache(const std::string& file, const Scan& scan) {
  std::ofstream out(file + ".tmp", std::ios::binary);
  const uint64_t n = scan.points.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  double T[16];
  for (int i = 0; i < 16; ++i) T[i] = scan.truth.matrix()(i / 4, i % 4);
  out.write(reinterpret_cast<const char*>(T), sizeof T);
  std::vector<float> xyz;
  for (const Vec3& p : scan.points)
    for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(p[k]));
  out.write(reinterpret_cast<const char*>(xyz.data()),
            static_cast<std::streamsize>(xyz.size() * sizeof(float)));
  out.write(reinterpret_cast<const char*>(scan.labels.data()), static_cast<std::streamsize>(n));
  xyz.clear();
  for (const Vec3& p : scan.viewpoints)
    for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(p[k]));
  out.write(reinterpret_cast<const char*>(xyz.data()),
            static_cast<std::streamsize>(xyz.size() * sizeof(float)));
  out.close();
  std::filesystem::rename(file + ".tmp", file);
}

struct PartData {
  std::string cell_file;
  TwinCell twin;
  std::shared_ptr<const PreparedPart> prepared;  ///< made ready once, shared by every trial and thread
};

// The part's seams sampled this densely to compare them with the part's own (seam_distance_m) [m].
constexpr double kTrueSeamSpacing_m = 1e-4;

struct Trial {
  size_t part = 0;
  uint64_t seed = 0;
  PoseEstimate ours, paper;
  PoseError ours_err, paper_err;
  std::vector<std::pair<std::string, PoseEstimate>> impostors;  // must all be refused
  size_t points = 0;
  size_t rescans = 0;  ///< rescans swept (TwinCell::sweep_again_because after the sweeps before each)
  // Ours' position error in the base frame: along the line from the robot's base axis to the part (negative:
  // towards the robot, where the LiDAR looks from) and across it (counter-clockwise) [m].
  double radial_m = 0.0, tangential_m = 0.0;
  /// The part off its CAD, found: the CAD's seams where ours put them against the part's own seams where
  /// they really are (seam_distance_m) [m]; -1: not measured.
  double true_seam_m = -1.0;
};

/// The base-frame position error split into radial and tangential parts (see Trial).
void split_error(const Iso3& found, const Iso3& truth, double& radial, double& tangential) {
  const Vec3 e = found.translation() - truth.translation();
  const Eigen::Vector2d out = truth.translation().head<2>().normalized();
  radial = e.head<2>().dot(out);
  tangential = out.x() * e.y() - out.y() * e.x();
}

/// The seeded LiDAR mount error of a trial: translation and rotation per axis N(0, sigma).
Iso3 mount_error(uint64_t seed, double sigma_m, double sigma_rad) {
  if (sigma_m <= 0 && sigma_rad <= 0) return Iso3::Identity();
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 17);
  std::normal_distribution<double> normal(0.0, 1.0);
  Vec3 t, r;
  for (int k = 0; k < 3; ++k) t[k] = sigma_m * normal(rng);
  for (int k = 0; k < 3; ++k) r[k] = sigma_rad * normal(rng);
  return make_transform(t, rpy_to_matrix(r.x(), r.y(), r.z()));
}

// Found, every seam point within the part's weld tolerance and turned by at most this.
constexpr double kMaxRotationRad = deg2rad(0.5);
bool success(const PoseEstimate& p, const PoseError& e, const PartSpec& part) {
  return p.found && e.seam_max_m <= part.weld_tolerance_m && e.rotation_rad <= kMaxRotationRad;
}

double pct(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::round(p * static_cast<double>(v.size() - 1)))];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Randomized localization benchmark on twin scans: ours and the paper's method side by side."};
  int layouts = 20, jobs = 2;
  uint64_t seed0 = 1;
  std::string cache, csv;
  bool no_paper = false, no_impostors = false, noise_free = false;
  std::vector<std::string> cells;
  std::string samples, real, real_part = "scenes/parts/paper_tee.yaml";
  std::vector<std::string> real_impostors;
  app.add_option(
      "--real", real,
      "also check the real scans of DIR (scan*.pcd, the part's mesh, nominal.json with the placement)");
  app.add_option("--real-part", real_part, "the part spec giving the real part's seams")
      ->capture_default_str();
  app.add_option("--real-impostor", real_impostors,
                 "other meshes sought in the real scans (must be refused)");
  app.add_option("--samples", samples,
                 "also localize every DIR/*/scan.pcd against its part.stl and truth.json");
  app.add_option("--layouts", layouts, "seeded cells per part")->capture_default_str();
  app.add_option("--seed", seed0, "first seed")->capture_default_str();
  app.add_option("--jobs", jobs, "cells in flight at once")->capture_default_str();
  app.add_option("--cache", cache, "directory keeping swept scans for re-runs");
  app.add_option("--csv", csv, "one line per trial");
  app.add_flag("--no-paper", no_paper, "skip the paper's pipeline");
  app.add_flag("--no-impostors", no_impostors, "skip the absent-part and wrong-part cases");
  int impostor_layouts = -1;
  app.add_option("--impostor-layouts", impostor_layouts,
                 "absent/wrong-part cases on the first N layouts of each part only (default: all)");
  std::vector<std::string> lidar_args;
  app.add_option("--lidar", lidar_args, "LiDAR setting override name=value (see sim/lidar_model.hpp)")
      ->allow_extra_args(false);
  app.add_flag("--noise-free", noise_free, "exact ranges, no dropouts or mixed pixels (to see biases)");
  bool no_viewpoints = false;
  std::string sweep_file;
  double mount_error_mm = 0.0, mount_error_deg = 0.0, part_deviation_mm = 0.0;
  app.add_option(
      "--sweep", sweep_file,
      "sweep program for every cell (default: each cell's own; it replaces the cell's rescan too)");
  std::vector<std::string> rescan_files;
  app.add_option(
         "--rescan", rescan_files,
         "where the part is refused (or found short of the 99 % bar), sweep this program too (it starts "
         "where the sweep ends) and seek the part in both sweeps, as a cell with `rescan:` does; given "
         "again, the next program, swept the same way (default: the cell's own, if any)")
      ->allow_extra_args(false);
  app.add_option(
      "--mount-error-mm", mount_error_mm,
      "the LiDAR mount off by a seeded draw, sigma per axis [mm] (the scan assembled with the nominal)");
  app.add_option("--mount-error-deg", mount_error_deg, "... and per rotation axis [deg]");
  bool calibrate = false;
  app.add_flag(
      "--calibrate", calibrate,
      "find the mount first from a sweep of the calibration cell through the same mount (as weldtwin "
      "calibrate), and assemble each scan with it");
  app.add_option("--part-deviation-mm", part_deviation_mm,
                 "the twin's part scaled by up to +-this in each dimension (its CAD unchanged) [mm]");
  int tack_welds = 0;
  double bend_deg = 0.0;
  app.add_option("--tack-welds", tack_welds, "the twin's part with this many tack welds on its seams (6 mm)");
  app.add_option("--bend-deg", bend_deg, "the twin's part bent along its length by up to +-this [deg]");
  app.add_flag("--no-viewpoints", no_viewpoints,
               "localize the clouds without their viewpoints, as other tools' clouds");
  app.add_option("cells", cells, "cell YAML files");
  CLI11_PARSE(app, argc, argv);
  std::map<std::string, double> lidar_overrides;
  for (const std::string& a : lidar_args) {
    const size_t eq = a.find('=');
    if (eq == std::string::npos) {
      std::fprintf(stderr, "localize_survey: --lidar takes name=value, not '%s'\n", a.c_str());
      return 2;
    }
    lidar_overrides[a.substr(0, eq)] = std::atof(a.c_str() + eq + 1);
  }
  try {
    if (!samples.empty() && !std::filesystem::is_directory(samples)) {
      std::fprintf(stderr, "localize_survey: no sample directory %s, skipped\n", samples.c_str());
    } else if (!samples.empty()) {
      std::vector<std::filesystem::path> dirs;
      for (const auto& e : std::filesystem::directory_iterator(samples))
        if (e.is_directory()) dirs.push_back(e.path());
      std::sort(dirs.begin(), dirs.end());
      for (const auto& dir : dirs) {
        const SampleTruth truth = read_sample_truth((dir / "truth.json").string());
        const Mesh mesh = load_mesh((dir / "part.stl").string());
        const std::vector<Vec3> cloud = read_cloud((dir / "scan.pcd").string());
        const PoseEstimate ours =
            localize(cloud, mesh, localize_setting_for(truth.part), truth.part.seam_points(0.001));
        const PoseError e =
            pose_error(truth.part, ours.T_base_part, truth.T_base_part, z_symmetry_order(mesh));
        std::printf(
            "sample %-26s %s: seam %.3f mm, rotation %.3f deg, %.2f s [cov %.2f fit %.2f free %.2f amb %.2f "
            "wall %.2f noise %.2f mm bound %.2f mm side %.1f beyond %.3f ext %.0f line %.2f of %.0f thru "
            "%.4f] %s\n",
            dir.filename().c_str(), ours.found ? "found  " : "refused", 1e3 * e.seam_max_m,
            rad2deg(e.rotation_rad), ours.seconds, ours.coverage, ours.fitness, ours.free_space,
            ours.ambiguity, ours.wall_residual, 1e3 * ours.noise_m, 1e3 * ours.seam_error_bound_m,
            ours.margin_llr, ours.beyond_share, 1e3 * ours.beyond_extent_m, ours.beyond_line_share,
            1e3 * ours.beyond_line_length_m, ours.see_through_share, ours.reason.c_str());
        if (!no_paper) {
          const PoseEstimate paper = localize_paper(cloud, mesh);
          const PoseError pe =
              pose_error(truth.part, paper.T_base_part, truth.T_base_part, z_symmetry_order(mesh));
          std::printf("       %-26s paper: seam %.3f mm, rotation %.3f deg, %.2f s\n", "",
                      1e3 * pe.seam_max_m, rad2deg(pe.rotation_rad), paper.seconds);
        }
      }
    }
    int real_failed = 0;
    if (!real.empty() && !std::filesystem::is_directory(real))
      std::fprintf(stderr, "localize_survey: no real scan directory %s, skipped\n", real.c_str());
    else if (!real.empty())
      real_failed = check_real_scans(real, real_part, real_impostors, !no_paper);
    if (cells.empty()) return real_failed ? 3 : 0;
    std::vector<PartData> parts;
    for (const std::string& f : cells) {
      PartData d{f, TwinCell(CellSpec::load(f), sweep_file, rescan_files), nullptr};
      d.prepared = std::make_shared<const PreparedPart>(d.twin.mesh);
      std::fprintf(stderr, "%s: z symmetry order %d\n", d.twin.part.name.c_str(), d.twin.symmetry);
      parts.push_back(std::move(d));
    }
    if (!cache.empty()) std::filesystem::create_directories(cache);
    std::string lidar_key;
    for (const auto& [k, v] : lidar_overrides) lidar_key += "-" + k + "=" + std::to_string(v);
    std::string condition_key;
    if (!sweep_file.empty()) condition_key += "-sweep=" + std::filesystem::path(sweep_file).stem().string();
    if (mount_error_mm > 0 || mount_error_deg > 0)
      condition_key += "-mount=" + std::to_string(mount_error_mm) + "," + std::to_string(mount_error_deg) +
                       (calibrate ? "-calibrated" : "");
    if (part_deviation_mm > 0) condition_key += "-deviation=" + std::to_string(part_deviation_mm);
    if (tack_welds > 0) condition_key += "-tacks=" + std::to_string(tack_welds);
    if (bend_deg > 0) condition_key += "-bend=" + std::to_string(bend_deg);
    PartDeviationSetting deviation;
    deviation.dimension_m = 1e-3 * part_deviation_mm;
    deviation.tack_welds = tack_welds;
    deviation.bend_deg = bend_deg;
    const RobotModel& robot = parts.front().twin.robot;
    std::optional<CalibrationCell> calibration;
    // The calibration cell beside the first cell given (scenes/cells/calibration.yaml).
    if (calibrate)
      calibration.emplace(
          CellSpec::load(
              (std::filesystem::path(parts.front().cell_file).parent_path() / "calibration.yaml").string()),
          robot);
    std::vector<double> calibration_error_mm(parts.size() * static_cast<size_t>(layouts), -1.0);
    std::vector<Trial> trials(parts.size() * static_cast<size_t>(layouts));
    std::vector<Iso3> scan_truth_of(trials.size(), Iso3::Identity());
    std::atomic<size_t> done{0};
    std::mutex io;
    parallel_for(trials.size(), std::max(1, jobs), [&](size_t i) {
      Trial& t = trials[i];
      t.part = i / static_cast<size_t>(layouts);
      t.seed = seed0 + i % static_cast<size_t>(layouts);
      const PartData& d = parts[t.part];
      // The cell's sweep by `program` (the LiDAR's noise drawn from `lidar_seed`), or its cached copy.
      auto sweep_scan = [&](const SweepProgram& program, uint64_t lidar_seed, const std::string& key) {
        Scan scan;
        const std::string file = cache.empty() ? ""
                                               : cache + "/" + d.twin.part.name + "-" +
                                                     std::to_string(t.seed) + (noise_free ? "-exact" : "") +
                                                     lidar_key + condition_key + key + ".scan";
        if (file.empty() || !read_cache(file, scan)) {
          const CellLayout layout = make_layout(d.twin.cell, d.twin.part, t.seed);
          // The real part may differ from its CAD: the twin's part off in each extent, with tack welds, bent
          // (the seams and the model stay the CAD's).
          PartSpec twin_part = d.twin.part;
          std::string deviated_mesh;
          if (deviation.any()) {
            deviated_mesh = (std::filesystem::temp_directory_path() /
                             ("weldtwin_survey_" + d.twin.part.name + "_" + std::to_string(t.seed) + ".stl"))
                                .string();
            write_stl(deviate_part(d.twin.mesh, d.twin.seam_points, deviation, t.seed).mesh, deviated_mesh,
                      "weldtwin survey: a part off its CAD");
            twin_part.mesh_path = deviated_mesh;
          }
          // An uncalibrated LiDAR mount: the twin (its MuJoCo model and its sweep) holds the LiDAR off by a
          // seeded draw, the scan is assembled with the nominal mount.
          const Iso3 mount_delta = mount_error(t.seed, 1e-3 * mount_error_mm, deg2rad(mount_error_deg));
          const TwinScene twin(d.twin, layout, mount_delta, &twin_part);
          const RobotModel& real_robot = twin.real_robot;
          const MujocoWorld& world = twin.world;
          if (!deviated_mesh.empty()) std::filesystem::remove(deviated_mesh);
          LidarSetting lidar = noise_free ? LidarSetting().noise_free() : LidarSetting();
          lidar.seed = lidar_seed;
          lidar.apply(lidar_overrides, "--lidar");
          SweepOptions opt;
          opt.threads = jobs > 1 ? 1 : 0;
          const SweepResult r = simulate_sweep(world, real_robot, program, lidar, opt);
          // Assembled with the URDF's mount, or with the one the calibration cell's sweep found.
          RobotModel assembly = robot;
          if (calibration) {
            const MountCalibration cal = calibrate_in_twin(*calibration, real_robot, robot, t.seed + 1, opt);
            assembly = robot.with_mount_offset("lidar", cal.delta);
            calibration_error_mm[i] = 1e3 * (cal.delta.translation() - mount_delta.translation()).norm();
          }
          const AssembledCloud cloud = assemble_scan(r.log, assembly);
          scan.points = cloud.points_base;
          scan.viewpoints = cloud.viewpoints_base;
          for (uint32_t s : cloud.sample_index) scan.labels.push_back(static_cast<uint8_t>(r.labels[s]));
          scan.truth = layout.T_base_part;
          round_as_cached(scan);
          if (!file.empty()) write_cache(file, scan);
        }
        if (no_viewpoints) scan.viewpoints.clear();
        return scan;
      };
      Scan scan = sweep_scan(d.twin.program, t.seed, "");
      t.points = scan.points.size();
      scan_truth_of[i] = scan.truth;
      auto find_ours = [&](const Scan& in) {
        WeldJob job;
        job.cell = &d.twin;
        job.prepared = d.prepared.get();
        job.T_base_part_twin = in.truth;
        job.truth_known = true;
        WeldPipelineSetting find_only;
        find_only.plan = false;
        const WeldPipelineResult found = weld_pipeline(in.points, in.viewpoints, job, find_only);
        t.ours = found.pose;
        t.ours_err = *found.pose_error;
      };
      find_ours(scan);
      // The sweeps so far, made once they are needed: where they leave the part (or an impostor) refused or
      // short of the 99 % bar, a cell with rescans sweeps the next and seeks the part in all of them. [k]:
      // the sweep and rescans 0..k.
      std::vector<Scan> rescanned;
      auto with_rescans = [&](size_t k) -> const Scan& {
        while (rescanned.size() <= k) {
          const size_t r = rescanned.size();
          const SweepProgram& program = d.twin.rescans[r];
          Scan all = r == 0 ? scan : rescanned.back();
          const Scan more = sweep_scan(program, rescan_lidar_seed(t.seed, r),
                                       "-rescan" + (r == 0 ? std::string() : std::to_string(r + 1)) + "=" +
                                           std::filesystem::path(program.source()).stem().string());
          all.points.insert(all.points.end(), more.points.begin(), more.points.end());
          all.labels.insert(all.labels.end(), more.labels.begin(), more.labels.end());
          all.viewpoints.insert(all.viewpoints.end(), more.viewpoints.begin(), more.viewpoints.end());
          rescanned.push_back(std::move(all));
        }
        return rescanned[k];
      };
      for (size_t k = 0; d.twin.sweeps_again(t.ours, k); ++k) {
        t.rescans = k + 1;
        find_ours(with_rescans(k));
      }
      if (deviation.any() && t.ours.found) {
        // The same draw the twin's part was made with (deterministic by seed): its seams as they really are.
        const DeviatedPart as_made = deviate_part(d.twin.mesh, d.twin.seam_points, deviation, t.seed);
        std::vector<Vec3> welded, really;
        for (const Vec3& p : d.twin.part.seam_points(kTrueSeamSpacing_m)) {
          welded.push_back(t.ours.T_base_part * p);
          really.push_back(scan.truth * as_made.apply(p));
        }
        t.true_seam_m = seam_distance_m(welded, really);
      }
      if (!no_paper) {
        t.paper = localize_paper(scan.points, d.twin.mesh);
        t.paper_err = pose_error(d.twin.part, t.paper.T_base_part, scan.truth, d.twin.symmetry);
      }
      if (!no_impostors &&
          (impostor_layouts < 0 || t.seed < seed0 + static_cast<uint64_t>(impostor_layouts))) {
        // Each sought again with the next rescan as the part is (TwinCell::sweep_again_because).
        auto seek = [&](const Scan& in, const PartData& sought, bool part_absent) {
          std::vector<Vec3> points, viewpoints;
          for (size_t k = 0; k < in.points.size(); ++k)
            if (!part_absent || in.labels[k] != static_cast<uint8_t>(Label::kPart)) {
              points.push_back(in.points[k]);
              if (!in.viewpoints.empty()) viewpoints.push_back(in.viewpoints[k]);
            }
          return localize(points, *sought.prepared, localize_setting_for(sought.twin),
                          sought.twin.seam_points, viewpoints);
        };
        auto impostor = [&](const std::string& what, const PartData& sought, bool part_absent) {
          PoseEstimate p = seek(scan, sought, part_absent);
          for (size_t k = 0; d.twin.sweeps_again(p, k); ++k) p = seek(with_rescans(k), sought, part_absent);
          t.impostors.emplace_back(what, p);
        };
        impostor("absent", d, true);
        for (const PartData& o : parts)
          if (o.twin.part.name != d.twin.part.name) impostor(o.twin.part.name, o, false);
      }
      std::lock_guard<std::mutex> lock(io);
      ++done;
      if (calibration_error_mm[i] >= 0)
        std::fprintf(stderr, "[calibrated mount %.2f mm off] ", calibration_error_mm[i]);
      std::fprintf(stderr, "[%zu/%zu] %s seed %llu: ours %s%s %.3f mm %.3f deg %.2f s", done.load(),
                   trials.size(), d.twin.part.name.c_str(), static_cast<unsigned long long>(t.seed),
                   t.rescans ? ("(rescanned " + std::to_string(t.rescans) + ") ").c_str() : "",
                   t.ours.found ? "found" : ("refused (" + t.ours.reason + ")").c_str(),
                   1e3 * t.ours_err.seam_max_m, rad2deg(t.ours_err.rotation_rad), t.ours.seconds);
      if (!no_paper)
        std::fprintf(stderr, " | paper %.3f mm %.3f deg %.2f s", 1e3 * t.paper_err.seam_max_m,
                     rad2deg(t.paper_err.rotation_rad), t.paper.seconds);
      {
        const Iso3 D = scan_truth_of[i].inverse() * t.ours.T_base_part;
        split_error(t.ours.T_base_part, scan_truth_of[i], t.radial_m, t.tangential_m);
        std::fprintf(stderr, " [base-frame error radial %.2f tangential %.2f mm]", 1e3 * t.radial_m,
                     1e3 * t.tangential_m);
        std::fprintf(stderr, " [part-frame error %.2f %.2f %.2f mm]", 1e3 * D.translation().x(),
                     1e3 * D.translation().y(), 1e3 * D.translation().z());
      }
      std::fprintf(
          stderr,
          " [cov %.2f fit %.2f free %.2f amb %.2f wall %.2f patch %.3f noise %.2f bound %.2f llr %.1f rllr "
          "%.1f wsig "
          "%.2f cells %.1f bias %.2f beyond %.3f ext %.0f thru %.4f reached %.2f tilt %.3f deg z %.2f mm "
          "edge %.2f mm "
          "%.2f deg region %d/%d line %.2f of %.0f at %.0f %.0f %.0f]",
          t.ours.coverage, t.ours.fitness, t.ours.free_space, t.ours.ambiguity, t.ours.wall_residual,
          t.ours.wall_patch_share, 1e3 * t.ours.noise_m, 1e3 * t.ours.seam_error_bound_m, t.ours.margin_llr,
          t.ours.residual_margin_llr, 1e3 * t.ours.wall_sigma_m, t.ours.bound_cells,
          1e3 * t.ours.wall_side_bias_m, t.ours.beyond_share, 1e3 * t.ours.beyond_extent_m,
          t.ours.see_through_share, t.ours.reached_coverage,
          rad2deg(std::acos(std::min(1.0, t.ours.table_plane.head<3>().normalized().z()))),
          -1e3 * t.ours.table_plane.w() / std::max(1e-9, t.ours.table_plane.head<3>().norm()),
          1e3 * t.ours.edge_shift_m, rad2deg(t.ours.edge_turn_rad), t.ours.region_through, t.ours.region_rays,
          t.ours.beyond_line_share, 1e3 * t.ours.beyond_line_length_m, 1e3 * t.ours.beyond_line_at_part.x(),
          1e3 * t.ours.beyond_line_at_part.y(), 1e3 * t.ours.beyond_line_at_part.z());
      for (const auto& [what, p] : t.impostors)
        std::fprintf(
            stderr,
            " | %s %s [cov %.2f fit %.2f free %.2f amb %.2f wall %.2f patch %.3f beyond %.3f ext %.0f thru "
            "%.4f reached "
            "%.2f bound %.2f region %d/%d line %.2f of %.0f] (%s)",
            p.found ? "FALSE ACCEPT" : "refused", what.c_str(), p.coverage, p.fitness, p.free_space,
            p.ambiguity, p.wall_residual, p.wall_patch_share, p.beyond_share, 1e3 * p.beyond_extent_m,
            p.see_through_share, p.reached_coverage, 1e3 * p.seam_error_bound_m, p.region_through,
            p.region_rays, p.beyond_line_share, 1e3 * p.beyond_line_length_m, p.reason.substr(0, 60).c_str());
      std::fprintf(stderr, "\n");
    });

    if (!csv.empty()) {
      std::ofstream out(csv);
      out << "part,seed,points,ours_found,ours_reason,ours_seam_max_mm,ours_seam_mean_mm,ours_rot_deg,ours_s,"
             "paper_seam_max_mm,paper_rot_deg,paper_s,false_accepts,ours_radial_mm,ours_tangential_mm,"
             "ours_bound_mm,ours_passes,ours_pass_apart_mm,ours_pass_excess_mm,ours_bound_cells,ours_"
             "rescanned,ours_yaw_bound_deg,ours_true_seam_max_mm\n";
      for (const Trial& t : trials) {
        int fa = 0;
        for (const auto& im : t.impostors) fa += im.second.found;
        out << parts[t.part].twin.part.name << ',' << t.seed << ',' << t.points << ',' << t.ours.found
            << ",\"" << t.ours.reason << "\"," << 1e3 * t.ours_err.seam_max_m << ','
            << 1e3 * t.ours_err.seam_mean_m << ',' << rad2deg(t.ours_err.rotation_rad) << ','
            << t.ours.seconds << ',' << 1e3 * t.paper_err.seam_max_m << ','
            << rad2deg(t.paper_err.rotation_rad) << ',' << t.paper.seconds << ',' << fa << ','
            << 1e3 * t.radial_m << ',' << 1e3 * t.tangential_m << ',' << 1e3 * t.ours.seam_error_bound_m
            << ',' << t.ours.passes_fitted << ',' << 1e3 * t.ours.pass_apart_m << ','
            << 1e3 * t.ours.pass_excess_m << ',' << t.ours.bound_cells << ',' << t.rescans << ','
            << rad2deg(t.ours.yaw_bound_rad) << ',' << 1e3 * t.true_seam_m << '\n';
      }
    }
    std::printf("%-15s %7s %9s %8s %8s %8s %8s %8s %9s %9s %8s\n", "part (method)", "trials", "success",
                "refused", "wrong", "seam p50", "seam p95", "seam max", "rot p95", "time p50", "impost.");
    int total_impostors = 0, total_false = 0;
    for (size_t p = 0; p < parts.size(); ++p)
      for (int method = 0; method < (no_paper ? 1 : 2); ++method) {
        int n = 0, ok = 0, refused = 0, wrong = 0, imp = 0, fa = 0;
        std::vector<double> seam, rot, secs;
        for (const Trial& t : trials) {
          if (t.part != p) continue;
          const PoseEstimate& e = method ? t.paper : t.ours;
          const PoseError& err = method ? t.paper_err : t.ours_err;
          ++n;
          ok += success(e, err, parts[p].twin.part);
          refused += !e.found;
          wrong +=
              e.found &&
              !success(e, err,
                       parts[p].twin.part);  // a confident wrong pose: the failure that welds the wrong place
          if (e.found) seam.push_back(1e3 * err.seam_max_m), rot.push_back(rad2deg(err.rotation_rad));
          secs.push_back(e.seconds);
          if (!method)
            for (const auto& im : t.impostors) ++imp, fa += im.second.found;
        }
        total_impostors += imp;
        total_false += fa;
        std::printf("%-15s %7d %8.1f%% %8d %8d %8.3f %8.3f %8.3f %9.3f %9.3f %8s\n",
                    (parts[p].twin.part.name.substr(0, 8) + (method ? " (paper)" : " (ours)")).c_str(), n,
                    100.0 * ok / std::max(1, n), refused, wrong, pct(seam, 0.5), pct(seam, 0.95),
                    pct(seam, 1.0), pct(rot, 0.95), pct(secs, 0.5),
                    method ? "" : (std::to_string(fa) + "/" + std::to_string(imp)).c_str());
      }
    std::printf(
        "seam errors in mm (found poses), rotation in deg, time in s; false accepts %d of %d "
        "absent/wrong-part "
        "cases\n",
        total_false, total_impostors);
    if (deviation.any()) {
      // The part off its CAD: the weld follows the CAD's seams where the pose puts them; what matters is how
      // far those are from the part's own.
      int found = 0, beyond = 0;
      double worst = 0.0;
      for (const Trial& t : trials) {
        if (t.true_seam_m < 0.0) continue;
        ++found;
        beyond += t.true_seam_m > parts[t.part].twin.part.weld_tolerance_m;
        worst = std::max(worst, t.true_seam_m);
      }
      std::printf(
          "ours against the part as it really is (its own seams, off the CAD's as its mesh): %d of %d found "
          "beyond the weld tolerance, the farthest %.3f mm\n",
          beyond, found, 1e3 * worst);
    }
    if (!parts.front().twin.rescans.empty()) {
      const TwinCell& first = parts.front().twin;
      std::vector<int> swept(first.rescans.size() + 1, 0);  // [k]: cells that swept k rescans
      double sweep_s = 0.0;
      for (const Trial& t : trials) {
        const TwinCell& c = parts[t.part].twin;
        ++swept[std::min(t.rescans, swept.size() - 1)];
        sweep_s += c.program.duration_s();
        for (size_t k = 0; k < t.rescans; ++k) sweep_s += c.rescans[k].duration_s();
      }
      std::string counts, seconds;
      for (size_t k = 0; k < first.rescans.size(); ++k) {
        int at_least = 0;
        for (size_t n = k + 1; n < swept.size(); ++n) at_least += swept[n];
        counts += k == 0 ? std::to_string(at_least) + " of " + std::to_string(trials.size()) + " cells"
                         : ", " + std::to_string(at_least) + " of them with rescan " + std::to_string(k + 1);
        seconds +=
            (k ? " + " : "") + std::to_string(static_cast<int>(std::lround(first.rescans[k].duration_s())));
      }
      std::printf("ours rescanned %s (sweep %.0f s, rescans %s s): %.1f s of sweeping per cell\n",
                  counts.c_str(), first.program.duration_s(), seconds.c_str(),
                  sweep_s / std::max<size_t>(1, trials.size()));
    }
    // A bias shows as a mean position error with a small spread: its direction says where it comes from
    // (radial: towards or away from the robot, which the LiDAR looks from).
    for (size_t p = 0; p < parts.size(); ++p) {
      std::vector<double> radial, tangential;
      for (const Trial& t : trials)
        if (t.part == p && t.ours.found)
          radial.push_back(1e3 * t.radial_m), tangential.push_back(1e3 * t.tangential_m);
      if (radial.size() < 2) continue;
      auto mean_sd = [](const std::vector<double>& v, double& mean, double& sd) {
        mean = 0.0;
        for (double x : v) mean += x;
        mean /= static_cast<double>(v.size());
        sd = 0.0;
        for (double x : v) sd += (x - mean) * (x - mean);
        sd = std::sqrt(sd / static_cast<double>(v.size() - 1));
      };
      double rm, rs, tm, ts;
      mean_sd(radial, rm, rs);
      mean_sd(tangential, tm, ts);
      std::printf(
          "%s (ours), base-frame position error: radial %+.3f mm (sd %.3f; negative: towards the robot), "
          "tangential %+.3f mm (sd %.3f)\n",
          parts[p].twin.part.name.c_str(), rm, rs, tm, ts);
    }
    // Per-stage time of ours (median over all trials; "model" is only a look-up: each part is prepared once)
    // and the two methods' time ratio on the same scans.
    std::map<std::string, std::vector<double>> stages;
    std::vector<double> ratio;
    for (const Trial& t : trials) {
      for (const auto& [name, sec] : t.ours.stage_seconds) stages[name].push_back(sec);
      if (!no_paper && t.ours.seconds > 0) ratio.push_back(t.paper.seconds / t.ours.seconds);
    }
    std::printf("ours, median time per stage [s]:");
    for (const auto& [name, v] : stages) std::printf(" %s %.3f", name.c_str(), pct(v, 0.5));
    if (!ratio.empty()) std::printf("; paper/ours time on the same scan: median %.2fx", pct(ratio, 0.5));
    std::printf("\n");
  } catch (const InputError& e) {
    std::fprintf(stderr, "localize_survey: %s\n", e.what());
    return 2;
  }
  return 0;
}
