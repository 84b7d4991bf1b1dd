#include "app/report.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <sstream>

#include "app/html_page.hpp"
#include "app/json_file.hpp"
#include "pipeline/outcome.hpp"
#include "sim/renderer.hpp"
#include "sim/weldability_picture.hpp"

namespace weldtwin {
namespace {

using html::num;
const auto& html_escape = html::escape;

Rgba label_colour(Label l) {
  switch (l) {
    case Label::kPart:
      return {1.0f, 0.55f, 0.05f, 1.0f};
    case Label::kTable:
      return {0.55f, 0.6f, 0.65f, 1.0f};
    case Label::kClamp:
      return {0.9f, 0.1f, 0.1f, 1.0f};
    case Label::kRobot:
      return {0.7f, 0.2f, 0.9f, 1.0f};
    default:
      return {0.2f, 0.75f, 0.25f, 1.0f};
  }
}

struct Picture {
  std::string file, title, caption;
};

// The pictures of the run, rendered offscreen, written as PNG files in `dir`.
std::vector<Picture> render_pictures(const RunRecord& run, const std::string& dir) {
  const MujocoWorld& world = *run.world;
  const mjModel* m = world.model();
  OffscreenRenderer renderer(m, std::min(800, m->vis.global.offwidth),
                             std::min(600, m->vis.global.offheight));
  DataPtr d = world.make_data();
  const PlanSetting defaults;
  world.set_joints(d.get(),
                   run.plan && !run.plan->samples.empty() ? run.plan->samples.front().q : defaults.home);
  std::vector<Picture> out;
  auto save = [&](const Image& img, const std::string& name, const std::string& title,
                  const std::string& caption) {
    img.write_png(dir + "/" + name);
    out.push_back({name, title, caption});
  };
  std::vector<uint8_t> robot_geoms;
  for (Label l : world.geom_labels()) robot_geoms.push_back(l == Label::kRobot);
  const Vec3 part_centre = run.layout->T_base_part * Vec3(0, 0, 0.5 * run.part->height_m);
  save(renderer.render(d.get(), View{"overview"}), "cell_overview.png", "The cell",
       "Overview camera, arm at home.");
  save(renderer.render(d.get(), View{"side"}), "cell_side.png", "The cell from the side", "Side camera.");

  // The scan, coloured by what each point hit, with the model where it was found.
  Overlay scan;
  const size_t stride = std::max<size_t>(1, run.cloud.size() / 30000);
  for (size_t i = 0; i < run.cloud.size(); i += stride) {
    if ((run.cloud[i] - part_centre).head<2>().norm() > 0.35) continue;
    scan.points.push_back(run.cloud[i]);
    scan.point_rgba.push_back(
        label_colour(i < run.cloud_labels.size() ? run.cloud_labels[i] : Label::kOther));
  }
  scan.ghost_mesh = mj_name2id(m, mjOBJ_MESH, "part_mesh");
  if (run.pose) {
    // MuJoCo keeps a mesh in its inertia frame: the part geom's offset in its body puts it back.
    const int part_geom = mj_name2id(m, mjOBJ_GEOM, "part");
    Iso3 T_body_geom = Iso3::Identity();
    if (part_geom >= 0) {
      const mjtNum* p = m->geom_pos + 3 * part_geom;
      const mjtNum* q = m->geom_quat + 4 * part_geom;
      T_body_geom = make_transform(Vec3(p[0], p[1], p[2]), Quat(q[0], q[1], q[2], q[3]).toRotationMatrix());
    }
    scan.ghost_pose = run.pose->T_base_part * T_body_geom;
  }
  if (!run.pose || !run.pose->found) scan.ghost_mesh = -1;
  scan.part_alpha = 0.0f;
  scan.hide_geom = robot_geoms;
  const View close{"", part_centre, 0.75, 150.0, -40.0};
  save(renderer.render(d.get(), close, scan), "scan_labels.png", "What the LiDAR saw",
       "Scan points near the part: part orange, table grey, clamps red, other green. Blue: the model at the "
       "pose "
       "found (the real part is hidden).");

  // The planned torch path, drawn on the part (the real one, where the twin knows it stands).
  if (run.plan && run.plan->samples.size() > 1) {
    Overlay path;
    path.hide_geom = robot_geoms;
    const auto& p = run.plan->samples;
    // Segments of about 2 mm (a capsule per 200 Hz sample would be thousands of shapes to draw).
    size_t from = 0;
    for (size_t k = 1; k < p.size(); ++k) {
      if (!p[k].arc || !p[k - 1].arc) {
        from = k;
        continue;
      }
      const Vec3 a = p[from].T_base_tcp.translation(), b = p[k].T_base_tcp.translation();
      if ((b - a).norm() >= 0.002 || k + 1 == p.size() || !p[k + 1].arc) {
        path.segments.emplace_back(a, b);
        from = k;
      }
    }
    path.segment_width_m = 0.0025;
    save(renderer.render(d.get(), View{"", part_centre, 0.38, 200.0, -45.0}, path), "torch_path.png",
         "The planned torch path on the part",
         "Yellow: the planned TCP while the arc is on, planned at the pose found, drawn on the part where it "
         "really stands.");
  }
  if (run.replay && !run.replay->samples.empty()) {
    const auto& s = run.replay->samples;
    // The arm at moments of the weld.
    std::vector<size_t> arc;
    for (size_t k = 0; k < s.size(); ++k)
      if (s[k].arc) arc.push_back(k);
    if (!arc.empty()) {
      int i = 0;
      for (double f : {0.0, 0.33, 0.66, 1.0}) {
        const size_t k =
            arc[std::min(arc.size() - 1, static_cast<size_t>(f * static_cast<double>(arc.size() - 1)))];
        world.set_joints(d.get(), s[k].q);
        char title[128];
        std::snprintf(title, sizeof title, "t = %.1f s", s[k].t_s);
        save(renderer.render(d.get(), View{"", part_centre, 1.1, 135.0, -25.0}),
             "arm_" + std::to_string(i++) + ".png", title,
             "The arm welding seam '" + run.part->seams[static_cast<size_t>(std::max(0, s[k].seam))].name +
                 "'.");
      }
    }
  }
  return out;
}

// Plots by gnuplot (PNG, cairo): joints against their limits, TCP speed, true-seam error.
std::vector<Picture> plot_figures(const RunRecord& run, const std::string& dir) {
  std::vector<Picture> out;
  if (!run.plan || run.plan->samples.size() < 3) return out;
  const auto& s = run.plan->samples;
  const double hz = 1.0 / std::max(1e-9, s[1].t_s - s[0].t_s);
  {
    std::ostringstream dat;
    for (size_t k = 1; k + 1 < s.size(); ++k) {
      dat << s[k].t_s;
      for (int j = 0; j < 6; ++j) dat << ' ' << rad2deg(s[k].q[j]);
      for (int j = 0; j < 6; ++j) dat << ' ' << (s[k + 1].q[j] - s[k - 1].q[j]) * 0.5 * hz;
      for (int j = 0; j < 6; ++j) dat << ' ' << (s[k + 1].q[j] - 2 * s[k].q[j] + s[k - 1].q[j]) * hz * hz;
      dat << '\n';
    }
    write_text_file(dir + "/plot_joints.dat", dat.str());
  }
  bool have_replay = run.replay && !run.replay->samples.empty();
  if (have_replay) {
    std::ostringstream dat;
    const auto& r = run.replay->samples;
    for (size_t k = 1; k < r.size(); ++k) {
      if (!r[k].arc || !r[k - 1].arc) continue;
      dat << r[k].t_s << ' ' << 1e3 * (r[k].tcp - r[k - 1].tcp).norm() / (r[k].t_s - r[k - 1].t_s) << ' '
          << 1e3 * r[k].seam_error_m << ' ' << 1e3 * r[k].clearance_m << '\n';
    }
    write_text_file(dir + "/plot_seams.dat", dat.str());
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size 900,360 font 'DejaVu Sans,10'\nset grid\nset key outside right\n"
     << "set xlabel 'time [s]'\n";
  const char* names[] = {"J1", "J2", "J3", "J4", "J5", "J6"};
  auto joints = [&](const std::string& file, const std::string& ylabel, int first_col, double lim13,
                    double lim46) {
    gp << "set output '" << dir << "/" << file << "'\nset ylabel '" << ylabel << "'\n";
    gp << "plot ";
    for (int j = 0; j < 6; ++j)
      gp << "'" << dir << "/plot_joints.dat' using 1:" << first_col + j << " with lines lw 1.5 title '"
         << names[j] << "', ";
    gp << lim13 << " with lines dt 2 lc rgb 'red' title 'limit J1-J3', " << -lim13
       << " with lines dt 2 lc rgb 'red' notitle, " << lim46
       << " with lines dt 3 lc rgb 'dark-red' title 'limit J4-J6', " << -lim46
       << " with lines dt 3 lc rgb 'dark-red' notitle\n";
  };
  joints("plot_joint_positions.png", "joint angle [deg]", 2, 175, 175);
  joints("plot_joint_velocities.png", "joint velocity [rad/s]", 8, 2.5, 3.2);
  joints("plot_joint_accelerations.png", "joint acceleration [rad/s^2]", 14, 17.2, 20.7);
  if (have_replay) {
    const double spec = run.part->seams.empty() ? 0.0 : 1e3 * run.part->seams.front().speed_m_s;
    gp << "set output '" << dir << "/plot_tcp_speed.png'\nset ylabel 'TCP speed [mm/s]'\n"
       << "plot '" << dir << "/plot_seams.dat' using 1:2 with points pt 7 ps 0.3 title 'replayed, arc on', "
       << spec << " with lines dt 2 lc rgb 'red' title 'seam speed'\n";
    gp << "set output '" << dir << "/plot_seam_error.png'\nset ylabel 'distance [mm]'\nset yrange [0:*]\n"
       << "plot '" << dir
       << "/plot_seams.dat' using 1:3 with points pt 7 ps 0.3 title 'torch to true seam', 1.0 with lines "
       << "dt 2 lc rgb 'red' title '1 mm bar'\n";
  }
  if (!html::gnuplot(dir, "plots.gp", gp.str())) return out;  // the report says the plots are missing
  out.push_back({"plot_joint_positions.png", "Joint positions", "Planned, against the +-175 deg limits."});
  out.push_back({"plot_joint_velocities.png", "Joint velocities", "Planned, against the limits."});
  out.push_back({"plot_joint_accelerations.png", "Joint accelerations", "Planned, against the limits."});
  if (have_replay) {
    out.push_back({"plot_tcp_speed.png", "TCP speed while welding", "Replayed arm, against the seam speed."});
    out.push_back({"plot_seam_error.png", "Torch to the true seam", "Every arc-on sample of the replay."});
  }
  for (const char* f : {"/plot_joints.dat", "/plot_seams.dat"}) std::filesystem::remove(dir + f);
  return out;
}

}  // namespace

nlohmann::json report_json(const RunRecord& run) {
  nlohmann::json j;
  j["verdict"] = run.passed ? "PASS" : "FAIL";
  j["reasons"] = run.reasons;
  j["cell"] = run.cell->source;
  j["seed"] = run.layout->seed ? nlohmann::json(*run.layout->seed) : nlohmann::json(nullptr);
  j["part"] = run.part->name;
  j["weld_tolerance_m"] = run.part->weld_tolerance_m;
  j["T_base_part_true"] = transform_json(run.layout->T_base_part);
  j["clamps"] = run.layout->clamps.size();
  j["scan_points"] = run.cloud.size();
  j["sweeps"] = run.sweeps;
  j["rescan_reasons"] = run.rescan_reasons;
  if (run.pose) {
    j["localization"] = {{"found", run.pose->found},
                         {"reason", run.pose->reason},
                         {"T_base_part", transform_json(run.pose->T_base_part)},
                         {"fitness", run.pose->fitness},
                         {"rmse_m", run.pose->rmse_m},
                         {"coverage", run.pose->coverage},
                         {"ambiguity", run.pose->ambiguity},
                         {"seam_error_bound_m", run.pose->seam_error_bound_m}};
    if (run.pose_error) {  // the truth is known only where the twin made the scan
      j["localization"]["seam_error_max_m"] = run.pose_error->seam_max_m;
      j["localization"]["seam_error_mean_m"] = run.pose_error->seam_mean_m;
      j["localization"]["rotation_error_deg"] = rad2deg(run.pose_error->rotation_rad);
    }
  }
  if (run.plan) {
    j["plan"] = {{"ok", run.plan->ok()},
                 {"problems", run.plan->problems},
                 {"notes", run.plan->notes},
                 {"duration_s", run.plan->duration_s()},
                 {"samples", run.plan->samples.size()},
                 {"seams", run.plan->seams.size()},
                 {"sha256", run.plan_sha256}};
    for (const PlannedSeam& s : run.plan->seams)
      j["plan"]["torch"].push_back({{"seam", s.name},
                                    {"work_angle_deg", rad2deg(s.work_angle_rad)},
                                    {"travel_angle_deg", rad2deg(s.travel_angle_rad)},
                                    {"torch_roll_deg", rad2deg(s.roll_rad)},
                                    {"reversed", s.reversed}});
  }
  if (run.replay) {
    const ReplayResult& r = *run.replay;
    nlohmann::json seams = nlohmann::json::array();
    for (const SeamFigure& f : r.seams)
      seams.push_back(
          {{"seam", f.name}, {"samples", f.samples}, {"max_m", f.max_error_m}, {"rms_m", f.rms_error_m}});
    nlohmann::json contacts = nlohmann::json::array();
    for (const ReplayContact& c : r.contacts)
      contacts.push_back({{"robot_geom", c.robot_geom},
                          {"other_geom", c.other_geom},
                          {"other", label_name(c.other)},
                          {"first_t_s", c.first_t_s},
                          {"last_t_s", c.last_t_s},
                          {"max_depth_m", c.max_depth_m}});
    j["replay"] = {{"passed", r.passed()},
                   {"failures", r.failures},
                   {"true_seam_error_max_m", r.max_seam_error_m},
                   {"true_seam_error", seams},
                   {"tracking_max_rad", r.max_tracking_rad},
                   {"tcp_tracking_max_m", r.max_tcp_tracking_m},
                   {"min_clearance_m", r.min_clearance_m},
                   {"min_clearance_geom", r.min_clearance_geom},
                   {"min_clearance_t_s", r.min_clearance_t_s},
                   {"contacts", contacts}};
  }
  if (run.suggestion) {
    const PlacementSuggestion& g = *run.suggestion;
    nlohmann::json sj = {{"found", g.found},
                         {"screened", g.screened},
                         {"planned_and_replayed", g.verified},
                         {"seconds", g.seconds}};
    if (g.found) {
      sj["instruction"] = g.instruction;
      sj["x_m"] = g.T_base_part.translation().x();
      sj["y_m"] = g.T_base_part.translation().y();
      sj["yaw_deg"] = rad2deg(std::atan2(g.T_base_part.linear()(1, 0), g.T_base_part.linear()(0, 0)));
      sj["move_mm"] = 1e3 * g.move_m;
      sj["turn_deg"] = rad2deg(g.turn_rad);
    } else {
      sj["reason"] = g.reason;
    }
    j["placement_suggestion"] = sj;
  }
  if (run.weldability) {
    const WeldabilityMap& m = *run.weldability;
    j["weldability_map"] = {{"grid_m", m.grid_m},
                            {"yaw_step_deg", rad2deg(m.yaw_step_rad)},
                            {"welds", m.count(PlacementKind::kWelds)},
                            {"out_of_reach", m.count(PlacementKind::kOutOfReach)},
                            {"collides", m.count(PlacementKind::kCollides)},
                            {"no_room", m.count(PlacementKind::kNoRoom)},
                            {"seconds", m.seconds},
                            {"picture", "weldability.png"}};
  }
  j["stage_seconds"] = nlohmann::json::object();
  for (const auto& [name, s] : run.stage_seconds) j["stage_seconds"][name] = s;
  return j;
}

double write_report(const RunRecord& run, const std::string& dir, bool renders) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Picture> pictures, plots;
  std::string missing;
  double render_s = 0.0;
  if (renders) {
    try {
      pictures = render_pictures(run, dir);
    } catch (const std::exception& e) {
      missing += std::string("Pictures could not be rendered: ") + e.what() + ". ";
    }
    render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    plots = plot_figures(run, dir);
    if (plots.empty() && run.plan && run.plan->samples.size() >= 3)
      missing += "Plots need gnuplot (scripts/setup). ";
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j = report_json(run);
  j["stage_seconds"]["report"] = seconds;
  j["stage_seconds"]["report_pictures"] = render_s;
  j["stage_seconds"]["report_plots"] = seconds - render_s;
  write_json_file(dir + "/report.json", j);

  const double tolerance_m = run.part->weld_tolerance_m;
  std::ostringstream h;
  h << html::page_head("weldtwin run: " + run.part->name);
  h << "<h1>weldtwin run — " << html_escape(run.part->name) << " in cell '" << html_escape(run.cell->name)
    << "'" << (run.layout->seed ? ", seed " + std::to_string(*run.layout->seed) : std::string()) << "</h1>\n";
  h << "<div class=\"verdict " << (run.passed ? "PASS" : "FAIL") << "\">" << (run.passed ? "PASS" : "FAIL");
  if (run.replay)
    h << " — torch within " << num(1e3 * run.replay->max_seam_error_m) << " mm of the true seam ("
      << tolerance_text(tolerance_m) << ")";
  h << "</div>\n";
  if (!run.plan_sha256.empty())
    h << "<p>Plan SHA-256 <code>" << run.plan_sha256 << "</code>: "
      << (run.passed ? "replayed and passed — the one plan <code>--execute</code> may send to a robot."
                     : "not passed — no robot will be sent it.")
      << "</p>\n";
  if (!run.reasons.empty()) {
    h << "<ul>";
    for (const auto& r : run.reasons) h << "<li class=\"bad\">" << html_escape(r) << "</li>";
    h << "</ul>\n";
  }
  if (run.suggestion) {
    h << "<h2>Where to put the part</h2>\n<p class=\"guidance\">"
      << html_escape(run.suggestion->found
                         ? run.suggestion->instruction + " — there it plans and replays clean in the twin."
                         : "No placement found: " + run.suggestion->reason)
      << "</p>\n";
  }
  if (run.weldability) {
    std::vector<MapMark> marks;
    if (run.pose && run.pose->found) {
      const Iso3& T = run.pose->T_base_part;
      marks.push_back(footprint_mark(*run.part, T.translation().x(), T.translation().y(),
                                     std::atan2(T.linear()(1, 0), T.linear()(0, 0)), {30, 60, 200}));
    }
    if (run.suggestion && run.suggestion->found) {
      const Iso3& T = run.suggestion->T_base_part;
      marks.push_back(footprint_mark(*run.part, T.translation().x(), T.translation().y(),
                                     std::atan2(T.linear()(1, 0), T.linear()(0, 0)), {150, 20, 170}));
    }
    weldability_picture(*run.weldability, marks).write_png(dir + "/weldability.png");
    h << html::figure(
        dir, "weldability.png", "Where this part welds on the table",
        "Seen from above, the robot (black) at the bottom edge. Green: the part welds there at that share "
        "of " +
            std::to_string(run.weldability->nyaw) +
            " yaws (every seam's stations reached clear of the cell, " + num(1e3 * run.weldability->grid_m) +
            " mm grid); red: the arm collides; orange: out of reach; " +
            "grey: no room for the part and its clamps. Blue outline: where the part was found; purple: " +
            "where to put it. The dot marks the same corner of the part in both.");
  }
  h << "<h2>Where the weld lands</h2>\n";
  if (run.replay) {
    h << "<p>Distance from the replayed torch (TCP) to the true seam at every arc-on sample ("
      << tolerance_text(tolerance_m) << ", the part's weld tolerance).</p>"
      << "<table><tr><th>seam</th><th>arc-on samples</th><th>max [mm]</th><th>RMS [mm]</th></tr>\n";
    for (const SeamFigure& f : run.replay->seams)
      h << "<tr><td>" << html_escape(f.name) << "</td><td>" << f.samples << "</td><td"
        << (f.max_error_m > tolerance_m ? " class=\"bad\"" : "") << ">" << num(1e3 * f.max_error_m)
        << "</td><td>" << num(1e3 * f.rms_error_m) << "</td></tr>\n";
    h << "</table>\n";
  } else {
    h << "<p class=\"bad\">Nothing was replayed.</p>\n";
  }
  h << "<h2>Figures</h2>\n<table>\n";
  auto row = [&](const std::string& k, const std::string& v, bool bad = false) {
    h << "<tr><th>" << k << "</th><td" << (bad ? " class=\"bad\"" : "") << ">" << html_escape(v)
      << "</td></tr>\n";
  };
  row("weld tolerance", num(1e3 * tolerance_m) + " mm: every seam point and arc-on torch position within it");
  if (!run.sweeps.empty()) {
    std::string names;  // each rescan with why it was swept
    for (size_t k = 0; k < run.sweeps.size(); ++k)
      names += (k ? "; " : "") + std::filesystem::path(run.sweeps[k]).stem().string() +
               (k && k <= run.rescan_reasons.size() ? " (" + run.rescan_reasons[k - 1] + ")" : "");
    row("sweeps", names + "; " + std::to_string(run.cloud.size()) + " points");
  }
  if (run.pose) {
    row("part found", run.pose->found ? "yes" : "no: " + run.pose->reason, !run.pose->found);
    row("fitness / coverage / ambiguity",
        num(run.pose->fitness, 2) + " / " + num(run.pose->coverage, 2) + " / " + num(run.pose->ambiguity, 2));
    row("inlier RMSE", num(1e3 * run.pose->rmse_m) + " mm");
    if (run.pose_error) {
      row("localization seam error (vs truth)",
          num(1e3 * run.pose_error->seam_max_m) + " mm max, " + num(1e3 * run.pose_error->seam_mean_m) +
              " mm mean",
          run.pose_error->seam_max_m > tolerance_m);
      row("localization rotation error", num(rad2deg(run.pose_error->rotation_rad)) + " deg");
    } else {
      row("localization seam error (vs truth)",
          "unknown: the scan is not the twin's, its truth is not known");
    }
  }
  if (run.plan) {
    row("plan", run.plan->ok() ? "ok" : run.plan->problems.front(), !run.plan->ok());
    row("plan duration",
        num(run.plan->duration_s(), 1) + " s, " + std::to_string(run.plan->samples.size()) + " samples");
    for (const PlannedSeam& s : run.plan->seams)
      row("torch on seam '" + s.name + "'", "work " + num(rad2deg(s.work_angle_rad), 0) + " deg, travel " +
                                                num(rad2deg(s.travel_angle_rad), 0) + " deg, roll " +
                                                num(rad2deg(s.roll_rad), 0) + " deg" +
                                                (s.reversed ? ", welded from its end to its start" : ""));
    for (const auto& n : run.plan->notes) row("plan note", n);
  }
  if (run.replay) {
    const ReplayResult& r = *run.replay;
    row("replay tracking error", num(r.max_tracking_rad, 6) + " rad max (joints), " +
                                     num(1e3 * r.max_tcp_tracking_m) + " mm max (TCP, arc on)");
    row("nozzle/robot clearance to the part",
        num(1e3 * r.min_clearance_m, 1) + " mm (" + r.min_clearance_geom +
            ", t = " + num(r.min_clearance_t_s, 2) + " s)",
        r.min_clearance_m < 1e-3);
    row("contacts", r.contacts.empty() ? "none" : std::to_string(r.contacts.size()), !r.contacts.empty());
    for (const ReplayContact& c : r.contacts)
      row("contact",
          c.robot_geom + " with " + c.other_geom + " from t = " + num(c.first_t_s, 2) + " s, " +
              num(1e3 * c.max_depth_m, 1) + " mm deep",
          true);
  }
  for (const auto& [name, s] : run.stage_seconds) row("time: " + name, num(s, 2) + " s");
  row("time: report", num(seconds, 2) + " s");
  h << "</table>\n";
  if (!missing.empty()) h << "<p class=\"bad\">" << html_escape(missing) << "</p>\n";
  auto figures = [&](const std::vector<Picture>& list) {
    for (const Picture& p : list) h << html::figure(dir, p.file, p.title, p.caption);
  };
  if (!pictures.empty()) {
    h << "<h2>The twin</h2>\n";
    figures(pictures);
  }
  if (!plots.empty()) {
    h << "<h2>Plots</h2>\n<div class=\"plots\">\n";
    figures(plots);
    h << "</div>\n";
  }
  h << "<p style=\"color:#777;font-size:.8em\">All figures: report.json beside this "
       "page.</p>\n</body></html>\n";
  write_text_file(dir + "/report.html", h.str());
  return seconds;
}

}  // namespace weldtwin
