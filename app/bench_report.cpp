// `weldtwin bench-report`: shards of one benchmark merged (by trial index), summarised with confidence
// intervals, and shown as a page with plots.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "app/bench_command.hpp"
#include "app/html_page.hpp"
#include "app/json_file.hpp"
#include "core/error.hpp"

namespace weldtwin {
namespace {

using nlohmann::json;

// A rate with its 95 % Wilson score interval.
json rate(size_t k, size_t n) {
  json j;
  j["count"] = k;
  j["of"] = n;
  if (n == 0) return j;
  const double z = 1.959964, nn = static_cast<double>(n), p = static_cast<double>(k) / nn;
  const double centre = (p + z * z / (2 * nn)) / (1 + z * z / nn);
  const double half = z * std::sqrt(p * (1 - p) / nn + z * z / (4 * nn * nn)) / (1 + z * z / nn);
  j["rate"] = p;
  j["ci95"] = {std::max(0.0, centre - half), std::min(1.0, centre + half)};
  return j;
}

json percentiles(std::vector<double> v) {
  json j;
  j["n"] = v.size();
  if (v.empty()) return j;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {
    return v[static_cast<size_t>(std::round(q * static_cast<double>(v.size() - 1)))];
  };
  double sum = 0;
  for (double x : v) sum += x;
  j["mean"] = sum / static_cast<double>(v.size());
  j["median"] = at(0.5);
  j["p95"] = at(0.95);
  j["max"] = v.back();
  return j;
}

bool flag(const json& j, const char* key, const char* field) {
  return j.contains(key) && j[key].is_object() && j[key].value(field, false);
}

// Reads and merges the shards; throws InputError naming the file and line for anything wrong.
std::map<uint64_t, json> merge(const std::vector<std::string>& inputs, uint64_t& seed) {
  std::map<uint64_t, json> trials;
  bool have_seed = false;
  for (const std::string& file : inputs) {
    std::ifstream in(file);
    if (!in) throw input_error(file, "cannot be read");
    std::string text;
    int line_no = 0;
    while (std::getline(in, text)) {
      ++line_no;
      if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
      const std::string where = "line " + std::to_string(line_no);
      json j;
      try {
        j = json::parse(text);
      } catch (const std::exception&) {
        throw input_error(file, where + " is not JSON (a truncated shard?)");
      }
      for (const char* key : {"index", "seed", "draw", "verdict", "seconds"})
        if (!j.contains(key))
          throw input_error(file, where + " has no '" + key + "': not a weldtwin bench line");
      const uint64_t s = j["seed"].get<uint64_t>();
      if (have_seed && s != seed)
        throw input_error(file, where + " is from seed " + std::to_string(s) + ", the others from " +
                                    std::to_string(seed) + ": shards of different benchmarks");
      seed = s;
      have_seed = true;
      const uint64_t index = j["index"].get<uint64_t>();
      auto [it, fresh] = trials.emplace(index, j);
      if (!fresh) {
        json a = it->second, b = j;
        a.erase("seconds");
        b.erase("seconds");
        if (a != b)
          throw input_error(
              file, where + ": trial " + std::to_string(index) + " is in two shards with different results");
      }
    }
  }
  if (trials.empty()) {
    std::string names;
    for (const std::string& f : inputs) names += (names.empty() ? "" : ", ") + f;
    throw input_error(names, "no trials in the input");
  }
  return trials;
}

json summarise(const std::map<uint64_t, json>& trials, uint64_t seed) {
  json s;
  s["seed"] = seed;
  s["trials"] = trials.size();
  const uint64_t last = trials.rbegin()->first;
  s["missing_indices"] = last + 1 - trials.size();
  struct Group {
    size_t n = 0, ours_under = 0, ours_success = 0, ours_found = 0, ours_false = 0, paper_under = 0,
           paper_success = 0, paper_n = 0, welded = 0, planned = 0, replayed = 0;
    size_t guided = 0, suggested = 0, suggestion_welded = 0;  // failures with the part found right
    std::vector<double> ours_mm, paper_mm, ours_deg, paper_deg;
  };
  std::map<std::string, Group> groups;  // "" = all
  std::map<std::string, std::vector<double>> seconds;
  std::map<std::string, size_t> kinds, causes;
  std::vector<double> calibration_mm, calibration_deg;  // with --calibrate: the mount found against the truth
  for (const auto& [index, j] : trials) {
    const std::string part = j["draw"].value("part", "?");
    for (const std::string& key : {std::string(), part}) {
      Group& g = groups[key];
      ++g.n;
      if (j.value("seams_under_1mm", false)) ++g.ours_under;
      if (flag(j, "ours", "success")) ++g.ours_success;
      if (flag(j, "ours", "found")) {
        ++g.ours_found;
        g.ours_mm.push_back(j["ours"]["seam_max_mm"].get<double>());
        g.ours_deg.push_back(j["ours"]["rotation_deg"].get<double>());
        if (j["ours"]["seam_max_mm"].get<double>() > 1.0) ++g.ours_false;
      }
      if (j.contains("paper")) {
        ++g.paper_n;
        const double mm = j["paper"]["seam_max_mm"].get<double>();
        if (j["paper"].value("found", false)) {
          g.paper_mm.push_back(mm);
          g.paper_deg.push_back(j["paper"]["rotation_deg"].get<double>());
          if (mm <= 1.0) ++g.paper_under;
        }
        if (flag(j, "paper", "success")) ++g.paper_success;
      }
      if (flag(j, "plan", "ok")) ++g.planned;
      if (j.contains("replay")) ++g.replayed;
      if (j.value("verdict", "") == "pass") ++g.welded;
      if (j.contains("guidance")) {
        ++g.guided;
        if (j["guidance"].value("found", false)) ++g.suggested;
        if (j["guidance"].contains("tried") && j["guidance"]["tried"].value("verdict", "") == "pass")
          ++g.suggestion_welded;
      }
    }
    if (j.contains("calibration")) {
      calibration_mm.push_back(j["calibration"].value("translation_error_mm", 0.0));
      calibration_deg.push_back(j["calibration"].value("rotation_error_deg", 0.0));
    }
    for (const auto& [stage, v] : j["seconds"].items())
      if (v.is_number()) seconds[stage].push_back(v.get<double>());
    if (j.contains("cause")) {
      ++kinds[j.value("cause_kind", "other")];
      // The cause without its numbers, so that alike causes count together.
      std::string c = j["cause"].get<std::string>(), t;
      for (size_t i = 0; i < c.size(); ++i)
        if (std::isdigit(static_cast<unsigned char>(c[i])) ||
            (c[i] == '.' && i + 1 < c.size() && std::isdigit(static_cast<unsigned char>(c[i + 1])))) {
          if (t.empty() || t.back() != '#') t += '#';
        } else {
          t += c[i];
        }
      ++causes[t];
    }
  }
  for (const auto& [key, g] : groups) {
    json p;
    p["trials"] = g.n;
    p["ours"]["seams_under_1mm"] = rate(g.ours_under, g.n);
    p["ours"]["localization_success"] = rate(g.ours_success, g.n);
    p["ours"]["found"] = g.ours_found;
    p["ours"]["false_accepts"] = g.ours_false;
    p["ours"]["seam_max_mm"] = percentiles(g.ours_mm);
    p["ours"]["rotation_deg"] = percentiles(g.ours_deg);
    if (g.paper_n > 0) {
      p["paper"]["seams_under_1mm"] = rate(g.paper_under, g.paper_n);
      p["paper"]["localization_success"] = rate(g.paper_success, g.paper_n);
      p["paper"]["seam_max_mm"] = percentiles(g.paper_mm);
      p["paper"]["rotation_deg"] = percentiles(g.paper_deg);
    }
    p["planned"] = rate(g.planned, g.n);
    p["welded"] = rate(g.welded, g.n);
    if (g.guided > 0)
      p["guidance"] = {{"failures_found_right", g.guided},
                       {"suggested", rate(g.suggested, g.guided)},
                       {"suggestion_welded", rate(g.suggestion_welded, g.guided)}};
    if (key.empty())
      s["overall"] = p;
    else
      s["parts"][key] = p;
  }
  if (!calibration_mm.empty()) {
    s["calibration"]["translation_error_mm"] = percentiles(calibration_mm);
    s["calibration"]["rotation_error_deg"] = percentiles(calibration_deg);
  }
  s["seconds"] = json::object();
  for (const auto& [stage, v] : seconds) s["seconds"][stage] = percentiles(v);
  s["failure_kinds"] = kinds;
  std::vector<std::pair<size_t, std::string>> sorted;
  for (const auto& [c, n] : causes) sorted.emplace_back(n, c);
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  for (const auto& [n, c] : sorted) s["failure_causes"].push_back({{"cause", c}, {"count", n}});
  return s;
}

// Plots: error CDFs of both methods, error against yaw, error against the clamp count.
std::vector<std::array<std::string, 3>> plots(const std::map<uint64_t, json>& trials,
                                              const std::string& dir) {
  std::vector<double> ours, paper;
  std::ostringstream scatter;
  for (const auto& [index, j] : trials) {
    const double yaw = j["draw"].value("yaw_deg", 0.0);
    // Clamp counts spread a little sideways (by index, so the picture is the same every time).
    const double clamps =
        j["draw"].value("clamps", 0) + 0.3 * (static_cast<double>((index * 37) % 101) / 100.0 - 0.5);
    const double o = flag(j, "ours", "found") ? j["ours"]["seam_max_mm"].get<double>() : -1;
    const double p = j.contains("paper") ? j["paper"]["seam_max_mm"].get<double>() : -1;
    if (o >= 0) ours.push_back(std::max(o, 1e-3));
    if (p >= 0) paper.push_back(std::max(p, 1e-3));
    scatter << yaw << ' ' << clamps << ' ' << (o >= 0 ? std::max(o, 1e-3) : NAN) << ' '
            << (p >= 0 ? std::max(p, 1e-3) : NAN) << '\n';
  }
  write_text_file(dir + "/bench_points.dat", scatter.str());
  const double n = static_cast<double>(trials.size());
  for (auto* v : {&ours, &paper}) std::sort(v->begin(), v->end());
  {
    std::ostringstream cdf;
    for (size_t k = 0; k < std::max(ours.size(), paper.size()); ++k) {
      cdf << (k < ours.size() ? ours[k] : NAN) << ' ' << static_cast<double>(k + 1) / n << ' '
          << (k < paper.size() ? paper[k] : NAN) << ' ' << static_cast<double>(k + 1) / n << '\n';
    }
    write_text_file(dir + "/bench_cdf.dat", cdf.str());
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size 900,380 font 'DejaVu Sans,10'\nset grid\nset key outside right\n"
     << "set datafile missing 'nan'\nset logscale x\nset format x '%g'\n"
     << "set output '" << dir << "/bench_cdf.png'\nset xlabel 'worst seam point off the truth [mm]'\n"
     << "set ylabel 'fraction of all trials'\nset yrange [0:1]\n"
     << "set arrow 1 from 1,0 to 1,1 nohead dt 2 lw 1.5 lc rgb 'red'\n"
     << "plot '" << dir << "/bench_cdf.dat' using 1:2 with steps lw 2 title 'ours (found)', '' using 3:4 "
     << "with steps lw 2 title 'paper'\nunset arrow 1\n"
     << "unset logscale x\nset logscale y\nset format y '%g'\nset yrange [*:*]\n"
     << "set output '" << dir << "/bench_yaw.png'\nset xlabel 'part yaw [deg]'\nset xrange [0:360]\n"
     << "set ylabel 'seam error [mm]'\n"
     << "plot '" << dir << "/bench_points.dat' using 1:3 with points pt 7 ps 0.5 title 'ours', '' using 1:4 "
     << "with points pt 6 ps 0.5 title 'paper', 1 with lines dt 2 lc rgb 'red' title '1 mm'\n"
     << "set output '" << dir << "/bench_clamps.png'\nset xlabel 'clamps'\nset xrange [1.5:4.5]\n"
     << "set xtics 1\nplot '" << dir << "/bench_points.dat' using 2:3 with points pt 7 ps 0.5 title 'ours', "
     << "'' using 2:4 with points pt 6 ps 0.5 title 'paper', 1 with lines dt 2 lc rgb 'red' title '1 mm'\n";
  std::vector<std::array<std::string, 3>> out;
  if (html::gnuplot(dir, "bench_plots.gp", gp.str())) {
    out.push_back({"bench_cdf.png", "Seam error, cumulative",
                   "Fraction of all trials whose worst seam point lies within x of the truth (ours: found "
                   "parts only; a refusal never reaches the top)."});
    out.push_back({"bench_yaw.png", "Seam error against the part's yaw", "Every trial, both methods."});
    out.push_back({"bench_clamps.png", "Seam error against the clamp count", "Every trial, both methods."});
  }
  for (const char* f : {"/bench_points.dat", "/bench_cdf.dat"}) std::filesystem::remove(dir + f);
  return out;
}

std::string pct_ci(const json& r) {
  if (!r.contains("rate")) return "-";
  return html::num(100 * r["rate"].get<double>(), 1) + " % (" + std::to_string(r["count"].get<size_t>()) +
         "/" + std::to_string(r["of"].get<size_t>()) + "; 95 % CI " +
         html::num(100 * r["ci95"][0].get<double>(), 1) + "-" +
         html::num(100 * r["ci95"][1].get<double>(), 1) + " %)";
}

// A table cell: the rate, and under it the counts and the interval in small print.
std::string rate_cell(const json& r) {
  if (!r.contains("rate")) return "-";
  return html::num(100 * r["rate"].get<double>(), 1) + " %<br><small>" +
         std::to_string(r["count"].get<size_t>()) + "/" + std::to_string(r["of"].get<size_t>()) + ", CI " +
         html::num(100 * r["ci95"][0].get<double>(), 1) + "-" +
         html::num(100 * r["ci95"][1].get<double>(), 1) + "</small>";
}

std::string mm3(const json& p) {
  if (!p.contains("median")) return "-";
  return html::num(p["median"].get<double>()) + " / " + html::num(p["p95"].get<double>()) + " / " +
         html::num(p["max"].get<double>());
}

}  // namespace

int run_bench_report(const BenchReportCommand& cmd) {
  if (cmd.inputs.empty()) throw InputError("bench-report: name at least one results file (JSON lines)");
  uint64_t seed = 0;
  const std::map<uint64_t, json> trials = merge(cmd.inputs, seed);
  std::error_code ec;
  std::filesystem::create_directories(cmd.out, ec);
  if (ec) throw input_error(cmd.out, "cannot create the output directory: " + ec.message());
  {
    std::string merged;
    for (const auto& [index, j] : trials) merged += j.dump() + '\n';
    write_text_file(cmd.out + "/results.jsonl", merged);
  }
  const json s = summarise(trials, seed);
  write_json_file(cmd.out + "/summary.json", s);
  const auto figures = plots(trials, cmd.out);

  const json& all = s["overall"];
  std::ostringstream h;
  h << html::page_head("weldtwin bench: " + std::to_string(trials.size()) + " trials");
  h << "<h1>weldtwin bench — " << trials.size() << " random cells, seed " << seed << "</h1>\n";
  const bool met = all["ours"]["seams_under_1mm"].value("rate", 0.0) >= 0.99;
  h << "<div class=\"verdict " << (met ? "PASS" : "FAIL") << "\">ours: every seam point within 1 mm in "
    << html::escape(pct_ci(all["ours"]["seams_under_1mm"])) << "</div>\n";
  if (s["missing_indices"].get<uint64_t>() > 0)
    h << "<p class=\"bad\">" << s["missing_indices"].get<uint64_t>()
      << " trial indices are missing (a shard not given?).</p>\n";
  h << "<p>Each trial: a random cell (part, pose anywhere within reach, any yaw, 2-4 clamps, clutter, LiDAR "
       "noise), swept in the twin, localized by ours and by the paper's pipeline on the same scan, then "
       "(ours) "
       "planned and replayed in MuJoCo. <b>Seams within 1 mm</b>: the part was found and every seam point "
       "lies "
       "within 1 mm of the true seam, by the pose and, where the plan was replayed, by the replayed torch "
       "too. "
       "<b>Localization success</b>: the issue's bar, 1 mm and 0.5 deg. <b>False accepts</b>: found, but a "
       "seam more than 1 mm off.</p>\n";
  // What a shop asks first: how many parts were welded, per part; then why not; then where to put them.
  h << "<h2>Welded end to end</h2>\n<p>Found, planned and replayed clean with the torch within 1 mm of the "
       "true seam.</p>\n<table><tr><th>part</th><th>trials</th><th>welded</th><th>failed though found within "
       "1 mm</th><th>a placement suggested</th><th>the suggestion welded (the whole trial again)</th></tr>\n";
  auto weld_row = [&](const std::string& name, const json& p) {
    const bool guided = p.contains("guidance");
    h << "<tr><td>" << html::escape(name) << "</td><td>" << p["trials"].get<size_t>() << "</td><td>"
      << rate_cell(p["welded"]) << "</td><td>"
      << (guided ? std::to_string(p["guidance"]["failures_found_right"].get<size_t>()) : "-") << "</td><td>"
      << (guided ? rate_cell(p["guidance"]["suggested"]) : "-") << "</td><td>"
      << (guided ? rate_cell(p["guidance"]["suggestion_welded"]) : "-") << "</td></tr>\n";
  };
  if (s.contains("parts"))
    for (const auto& [name, p] : s["parts"].items()) weld_row(name, p);
  weld_row("all", all);
  h << "</table>\n";
  if (!all.contains("guidance"))
    h << "<p>Placement guidance was not asked (<code>weldtwin bench --guidance</code>).</p>\n";
  h << "<h2>Success</h2>\n<table><tr><th>part</th><th>trials</th><th>ours: seams within 1 mm</th><th>paper: "
       "seams within 1 mm</th><th>ours: 1 mm and 0.5 deg</th><th>paper: 1 mm and 0.5 deg</th><th>ours: false "
       "accepts</th><th>planned</th><th>welded (replay passed)</th></tr>\n";
  auto row = [&](const std::string& name, const json& p) {
    const bool paper = p.contains("paper");
    h << "<tr><td>" << html::escape(name) << "</td><td>" << p["trials"].get<size_t>() << "</td><td>"
      << rate_cell(p["ours"]["seams_under_1mm"]) << "</td><td>"
      << (paper ? rate_cell(p["paper"]["seams_under_1mm"]) : "-") << "</td><td>"
      << rate_cell(p["ours"]["localization_success"]) << "</td><td>"
      << (paper ? rate_cell(p["paper"]["localization_success"]) : "-") << "</td><td"
      << (p["ours"]["false_accepts"].get<size_t>() > 0 ? " class=\"bad\"" : "") << ">"
      << p["ours"]["false_accepts"].get<size_t>() << "</td><td>" << rate_cell(p["planned"]) << "</td><td>"
      << rate_cell(p["welded"]) << "</td></tr>\n";
  };
  if (s.contains("parts"))
    for (const auto& [name, p] : s["parts"].items()) row(name, p);
  row("all", all);
  h << "</table>\n<h2>Errors</h2>\n<table><tr><th>part</th><th>ours seam error median / p95 / max "
       "[mm]</th><th>paper</th><th>ours rotation [deg]</th><th>paper</th></tr>\n";
  auto err_row = [&](const std::string& name, const json& p) {
    const bool paper = p.contains("paper");
    h << "<tr><td>" << html::escape(name) << "</td><td>" << mm3(p["ours"]["seam_max_mm"]) << "</td><td>"
      << (paper ? mm3(p["paper"]["seam_max_mm"]) : "-") << "</td><td>" << mm3(p["ours"]["rotation_deg"])
      << "</td><td>" << (paper ? mm3(p["paper"]["rotation_deg"]) : "-") << "</td></tr>\n";
  };
  if (s.contains("parts"))
    for (const auto& [name, p] : s["parts"].items()) err_row(name, p);
  err_row("all", all);
  h << "</table>\n<h2>Time per stage [s]</h2>\n<table><tr><th>stage</th><th>mean</th><th>median</th><th>p95"
       "</th><th>max</th></tr>\n";
  std::vector<std::string> stages;  // in the order of a trial, then any others
  for (const char* k :
       {"world", "sweep", "calibrate", "assemble", "ours", "paper", "plan", "replay", "total"})
    if (s["seconds"].contains(k)) stages.push_back(k);
  for (const auto& [stage, p] : s["seconds"].items())
    if (std::find(stages.begin(), stages.end(), stage) == stages.end()) stages.push_back(stage);
  for (const std::string& stage : stages) {
    const json& p = s["seconds"][stage];
    h << "<tr><td>" << html::escape(stage) << "</td><td>" << html::num(p["mean"].get<double>(), 2)
      << "</td><td>" << html::num(p["median"].get<double>(), 2) << "</td><td>"
      << html::num(p["p95"].get<double>(), 2) << "</td><td>" << html::num(p["max"].get<double>(), 2)
      << "</td></tr>\n";
  }
  h << "</table>\n";
  if (s.contains("calibration"))
    h << "<h2>LiDAR mount calibration</h2>\n<p>Each trial's mount, found from a sweep of the calibration "
         "cell, "
         "against the mount error put in: translation "
      << mm3(s["calibration"]["translation_error_mm"]) << " mm, rotation "
      << mm3(s["calibration"]["rotation_error_deg"]) << " deg (median / p95 / max).</p>\n";
  h << "<h2>Why trials failed</h2>\n";
  if (!s.contains("failure_causes")) {
    h << "<p>None did.</p>\n";
  } else {
    h << "<table><tr><th>kind</th><th>trials</th></tr>\n";
    for (const auto& [kind, n] : s["failure_kinds"].items())
      h << "<tr><td>" << html::escape(kind) << "</td><td>" << n.get<size_t>() << "</td></tr>\n";
    h << "</table>\n<table><tr><th>cause (# stands for numbers)</th><th>trials</th></tr>\n";
    for (const json& c : s["failure_causes"])
      h << "<tr><td>" << html::escape(c["cause"].get<std::string>()) << "</td><td>"
        << c["count"].get<size_t>() << "</td></tr>\n";
    h << "</table>\n";
  }
  if (!figures.empty()) {
    h << "<h2>Plots</h2>\n<div class=\"plots\">\n";
    for (const auto& f : figures) h << html::figure(cmd.out, f[0], f[1], f[2]);
    h << "</div>\n";
  } else {
    h << "<p class=\"bad\">Plots need gnuplot (scripts/setup).</p>\n";
  }
  h << "<p style=\"color:#777;font-size:.8em\">All figures: summary.json beside this page; every trial: "
       "results.jsonl.</p>\n</body></html>\n";
  write_text_file(cmd.out + "/report.html", h.str());
  std::printf("bench-report: %zu trials; ours seams within 1 mm %s; paper %s; report %s/report.html\n",
              trials.size(), pct_ci(all["ours"]["seams_under_1mm"]).c_str(),
              all.contains("paper") ? pct_ci(all["paper"]["seams_under_1mm"]).c_str() : "-", cmd.out.c_str());
  return 0;
}

}  // namespace weldtwin
