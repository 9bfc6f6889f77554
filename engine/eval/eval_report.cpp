#include "engine/eval/eval_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "core/version.hpp"
#include "engine/eval/eval_methods.hpp"
#include "engine/eval/svg_plot.hpp"

namespace mocap::engine::eval {
namespace {

// A table both renderers share: a caption, a header row and body rows of text cells.
struct Table {
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

std::string number(double v, int decimals) {
  if (std::isnan(v)) return "n/a";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.{}f}", v, decimals);
}

std::size_t total_frames(const EvalResults& r) {
  std::size_t frames = 0;
  for (const EvalClip& c : r.clips) frames += std::size_t(c.clean.frames);
  return frames;
}

constexpr const char* kEdgeNote =
    "; * best grid point on the edge of its grid (widen it with --grid)";

// A table of one score per method and condition, "best / auto", plus the unfiltered row.
Table score_table(const EvalResults& r, const EvalConfig& config, const std::string& caption,
                  const std::function<double(const Score&)>& metric, int decimals,
                  bool with_noisy = true) {
  Table t;
  t.caption = caption;
  t.header.push_back("method");
  for (const NoiseCondition& c : config.conditions) t.header.push_back(c.label());
  if (with_noisy) {
    std::vector<std::string> row{"noisy input"};
    for (std::size_t c = 0; c < config.conditions.size(); ++c)
      row.push_back(number(metric(pooled_noisy(r, c)), decimals));
    t.rows.push_back(row);
  }
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    std::vector<std::string> row{label(config.grids[m])};
    const std::size_t automatic = config.grids[m].points.size();
    for (std::size_t c = 0; c < config.conditions.size(); ++c) {
      const int best = best_point(r, config, m, c);
      const double b = best < 0 ? std::nan("") : metric(pooled(r, m, std::size_t(best), c));
      // "*": the best point sits on the edge of its grid; the true best may lie beyond it.
      const bool edge = best >= 0 && !edge_parameters(config.grids[m], std::size_t(best)).empty();
      if (edge && t.caption.find(kEdgeNote) == std::string::npos) t.caption += kEdgeNote;
      row.push_back(number(b, decimals) + (edge ? "*" : "") + " / " +
                    number(metric(pooled(r, m, automatic, c)), decimals));
    }
    t.rows.push_back(row);
  }
  return t;
}

Table best_parameter_table(const EvalResults& r, const EvalConfig& config) {
  Table t;
  t.caption = "The best grid point per method and condition (highest pooled PSNR)";
  t.header.push_back("method");
  for (const NoiseCondition& c : config.conditions) t.header.push_back(c.label());
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    std::vector<std::string> row{label(config.grids[m])};
    for (std::size_t c = 0; c < config.conditions.size(); ++c) {
      const int best = best_point(r, config, m, c);
      std::string cell = best < 0 ? "n/a" : describe(config.grids[m].points[std::size_t(best)]);
      std::string edges;
      for (const std::string& e : best < 0 ? std::vector<std::string>{}
                                           : edge_parameters(config.grids[m], std::size_t(best)))
        edges += (edges.empty() ? "" : ", ") + e;
      if (!edges.empty()) cell += " (edge: " + edges + ")";
      row.push_back(cell);
    }
    t.rows.push_back(row);
  }
  return t;
}

// Per clip, how far the clips spread around the pooled score.
Table spread_table(const EvalResults& r, const EvalConfig& config) {
  Table t;
  t.caption =
      "Rotation PSNR per clip, dB: min / median / max over clips (best grid point; "
      "automatic parameters)";
  t.header.push_back("method");
  for (const NoiseCondition& c : config.conditions) t.header.push_back(c.label());
  auto text = [](const Spread& s) {
    return number(s.min, 2) + " / " + number(s.median, 2) + " / " + number(s.max, 2);
  };
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    std::vector<std::string> row{label(config.grids[m])};
    for (std::size_t c = 0; c < config.conditions.size(); ++c) {
      const int best = best_point(r, config, m, c);
      row.push_back(
          (best < 0 ? std::string("n/a") : text(psnr_spread(r, m, std::size_t(best), c))) + "; " +
          text(psnr_spread(r, m, config.grids[m].points.size(), c)));
    }
    t.rows.push_back(row);
  }
  return t;
}

std::vector<Table> all_tables(const EvalResults& r, const EvalConfig& config) {
  const std::string pool =
      fmt::format("pooled over {} clips, {} frames; best grid point / automatic", r.clips.size(),
                  total_frames(r));
  Table skating = score_table(
      r, config, "Foot skating, % of foot steps (" + pool + ")",
      [](const Score& s) { return s.skating_percent(); }, 2);
  double clean_steps = 0, clean_skates = 0;
  for (const EvalClip& c : r.clips) {
    clean_skates += c.reference.clean_skating.skate_steps;
    clean_steps += c.reference.clean_skating.foot_steps;
  }
  skating.caption +=
      fmt::format("; the clean clips themselves: {}%",
                  number(clean_steps > 0 ? 100 * clean_skates / clean_steps : NAN, 2));
  // The clean captures' own jitter and skating (mm), for the ratios "x the capture's".
  PositionSums clean;
  for (const EvalClip& c : r.clips) clean.add(c.reference.clean_positions);
  const double clean_jitter = clean.jitter(), clean_skating = clean.skating();
  return {
      score_table(
          r, config, "Joint position error (MPJPE, all joints), mm (" + pool + ")",
          [](const Score& s) { return s.mpjpe_mm(); }, 2),
      score_table(
          r, config,
          fmt::format("Jitter of the joint positions, x the clean capture's ({} mm/frame^2) (",
                      number(clean_jitter, 3)) +
              pool + ")",
          [clean_jitter](const Score& s) { return s.jitter_mm() / clean_jitter; }, 2),
      score_table(
          r, config,
          fmt::format("Foot skating over the clean capture's contact frames, x the capture's ({} "
                      "mm/frame) (",
                      number(clean_skating, 3)) +
              pool + ")",
          [clean_skating](const Score& s) { return s.skating_mm() / clean_skating; }, 2),
      score_table(
          r, config,
          "Peak knee angular speed, x the clean capture's, the largest over clips (" + pool + ")",
          [](const Score& s) { return s.knee_peak_ratio; }, 2),
      score_table(
          r, config, "Acceleration error of the joint positions, mm/frame^2 (" + pool + ")",
          [](const Score& s) { return s.accel_error_mm(); }, 3),
      score_table(
          r, config, "Rotation PSNR, dB (" + pool + ")", [](const Score& s) { return s.psnr(); },
          2),
      score_table(
          r, config, "Rotation RMSE, mrad (" + pool + ")",
          [](const Score& s) { return 1000 * s.rmse(); }, 2),
      score_table(
          r, config, "End-effector (hands, feet) position RMSE, cm (" + pool + ")",
          [](const Score& s) { return s.effector_rms_cm(); }, 3),
      skating,
      score_table(
          r, config, "Angular speed profile error, RMS rad/s (" + pool + ")",
          [](const Score& s) { return s.speed_rms(); }, 3),
      score_table(
          r, config,
          "Worst rotation error, rad, of any joint that is not garbage in the clean clip (" + pool +
              ")",
          [](const Score& s) { return s.max_error; }, 3),
      best_parameter_table(r, config),
  };
}

// Per clip, the targets of foot locking (docs/feet.md), automatic parameters without / with
// locking: skating over the clean capture's contacts, x the capture's; the knees' peak angular
// speed, x the capture's; MPJPE, x the noisy input's.
std::vector<Table> feet_tables(const EvalResults& r, const EvalConfig& config) {
  std::vector<Table> out;
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    if (!locked_twin(config.grids, m)) continue;
    const int twin = int(m) - 1;
    const std::size_t on_auto = config.grids[m].points.size(),
                      off_auto = config.grids[std::size_t(twin)].points.size();
    for (std::size_t c = 0; c < config.conditions.size(); ++c) {
      Table t;
      t.caption = fmt::format(
          "Feet per clip, {} vs {} (automatic parameters), {}: skating over the clean capture's "
          "contacts, x the capture's; peak knee angular speed, x the capture's; MPJPE, x the "
          "noisy input's (without / with locking)",
          label(config.grids[std::size_t(twin)]), label(config.grids[m]),
          config.conditions[c].label());
      t.header = {"clip", "skating", "knee peak", "MPJPE"};
      for (std::size_t k = 0; k < r.clips.size(); ++k) {
        const Score& off = r.results[std::size_t(twin)][off_auto][c][k].score;
        const Score& on = r.results[m][on_auto][c][k].score;
        const double capture = r.clips[k].reference.clean_positions.skating();
        const double noisy = r.noisy_scores[c][k].mpjpe_mm();
        auto pair = [](double a, double b) { return number(a, 2) + " / " + number(b, 2); };
        t.rows.push_back(
            {r.clips[k].name, pair(off.skating_mm() / capture, on.skating_mm() / capture),
             pair(off.knee_peak_ratio, on.knee_peak_ratio),
             noisy > 0 ? pair(off.mpjpe_mm() / noisy, on.mpjpe_mm() / noisy) : std::string("n/a")});
      }
      out.push_back(std::move(t));
    }
  }
  return out;
}

std::string to_markdown(const Table& t) {
  std::string out = "**" + t.caption + "**\n\n|";
  for (const auto& h : t.header) out += " " + h + " |";
  out += "\n|";
  for (std::size_t i = 0; i < t.header.size(); ++i) out += i == 0 ? " --- |" : " ---: |";
  out += "\n";
  for (const auto& row : t.rows) {
    out += "|";
    for (const auto& cell : row) out += " " + cell + " |";
    out += "\n";
  }
  return out;
}

std::string to_html(const Table& t) {
  std::string out = "<table>\n<caption>" + escape_xml(t.caption) + "</caption>\n<tr>";
  for (const auto& h : t.header) out += "<th>" + escape_xml(h) + "</th>";
  out += "</tr>\n";
  for (const auto& row : t.rows) {
    out += "<tr>";
    for (std::size_t i = 0; i < row.size(); ++i)
      out += (i == 0 ? "<th>" : "<td>") + escape_xml(row[i]) + (i == 0 ? "</th>" : "</td>");
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

int contact_frames(const std::vector<std::vector<ContactInterval>>& contacts) {
  int n = 0;
  for (const auto& foot : contacts)
    for (const ContactInterval& c : foot) n += c.frames();
  return n;
}

nlohmann::json json_number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json score_json(const Score& s) {
  return {{"rmse_rad", json_number(s.rmse())},
          {"psnr_db", json_number(s.psnr())},
          {"psnr_db_unglitched", json_number(s.unglitched_psnr())},
          {"end_effector_rmse_cm", json_number(s.effector_rms_cm())},
          {"foot_skating_percent", json_number(s.skating_percent())},
          {"angular_speed_rms_error", json_number(s.speed_rms())},
          {"mpjpe_mm", json_number(s.mpjpe_mm())},
          {"jitter_mm", json_number(s.jitter_mm())},
          {"acceleration_error_mm", json_number(s.accel_error_mm())},
          {"foot_skating_mm", json_number(s.skating_mm())},
          {"knee_peak_speed_ratio", json_number(s.knee_peak_ratio)}};
}

nlohmann::json point_json(const ParamPoint& p) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : p) j[name] = value;
  return j;
}

}  // namespace

std::string psnr_table(const EvalResults& results, const EvalConfig& config) {
  return to_markdown(all_tables(results, config).front());
}

std::string markdown_report(const EvalResults& results, const EvalConfig& config) {
  std::string out;
  for (const Table& t : all_tables(results, config)) out += to_markdown(t) + "\n";
  for (const Table& t : feet_tables(results, config)) out += to_markdown(t) + "\n";
  return out;
}

nlohmann::json report_json(const EvalResults& r, const EvalConfig& config) {
  nlohmann::json j;
  j["engine_version"] = std::string(kVersion);
  j["seed"] = config.seed;
  j["split_impossible"] = config.split_impossible;
  j["pop_stage"] = config.pop_stage == PopsMode::repair ? "repair" : "auto";
  j["guard"] = config.guard;  // auto's runs end with clean's guard (engine/clip/motion_guard.hpp)
  j["split_max_speed_rad_s"] = config.split.max_speed;
  j["split_max_step_rad"] = config.split.max_step;
  j["split_min_pose_step_rad"] = config.split.min_pose_step;
  j["split_max_pose_speed_rad_s"] = config.split.max_pose_speed;
  j["timing"] = {{"prepare_seconds", r.prepare_seconds},
                 {"filter_seconds", r.filter_seconds},
                 {"tasks", r.tasks}};
  nlohmann::json clips = nlohmann::json::array();
  for (const EvalClip& c : r.clips) {
    nlohmann::json steps = nlohmann::json::array(), segments = nlohmann::json::array(),
                   effectors = nlohmann::json::array();
    for (const ImpossibleStep& s : c.steps)
      steps.push_back({{"frame", s.frame},
                       {"joint", c.clean.skeleton->joint_names[std::size_t(s.joint)]},
                       {"angle_rad", s.angle}});
    for (const Segment& s : c.segments) segments.push_back({s.begin, s.end});
    for (const Effector& e : c.geometry.effectors)
      effectors.push_back({{"name", e.name}, {"foot", e.foot}});
    const Score& sk = c.reference.clean_skating;
    clips.push_back({{"name", c.name},
                     {"frames", c.clean.frames},
                     {"joints", c.clean.joints()},
                     {"frame_time", c.clean.frame_time},
                     {"impossible_steps", steps},
                     {"segments", segments},
                     {"effectors", effectors},
                     {"effectors_by_name", c.geometry.by_name},
                     {"unit_cm", c.geometry.unit_cm},
                     {"unit_guessed", c.geometry.unit_guessed},
                     {"hip_height_units", c.geometry.hip_height_units},
                     {"clean_foot_skating_percent", json_number(sk.skating_percent())},
                     {"body_height_units", c.geometry.body_height_units},
                     {"clean_jitter_mm", json_number(c.reference.clean_positions.jitter())},
                     {"reference_glitches",
                      std::count(c.reference.glitches.begin(), c.reference.glitches.end(), 1)},
                     {"clean_foot_skating_mm", json_number(c.reference.clean_positions.skating())},
                     {"contact_frames", contact_frames(c.reference.contacts)}});
  }
  j["clips"] = clips;

  nlohmann::json conditions = nlohmann::json::array();
  for (std::size_t c = 0; c < config.conditions.size(); ++c) {
    const NoiseCondition& nc = config.conditions[c];
    nlohmann::json cj{{"label", nc.label()}};
    if (nc.is_gaussian()) {
      cj["model"] = "gaussian";
      cj["sigma"] = nc.sigma;
    } else {
      cj["model"] = "impulse";
      cj["rate"] = nc.impulse.rate;
      cj["min_angle"] = nc.impulse.min_angle;
      cj["max_angle"] = nc.impulse.max_angle;
    }
    cj["noisy"] = score_json(pooled_noisy(r, c));
    nlohmann::json sigma_hats = nlohmann::json::array();
    for (const NoisyClip& n : r.noisy[c]) sigma_hats.push_back(n.sigma_hats);
    cj["sigma_hat_per_clip_segment"] = sigma_hats;
    // Per clip: the noisy input's PSNR, and what the pop stage found in it (garbage joints are
    // the ones classified on the noisy clip, as the engine sees it).
    nlohmann::json per_clip = nlohmann::json::array();
    for (std::size_t k = 0; k < r.clips.size(); ++k) {
      const NoisyClip& n = r.noisy[c][k];
      const auto& names = r.clips[k].clean.skeleton->joint_names;
      nlohmann::json garbage = nlohmann::json::array();
      for (std::size_t jt = 0; jt < n.garbage.size(); ++jt)
        if (n.garbage[jt]) garbage.push_back(names[jt]);
      nlohmann::json left = nlohmann::json::array();
      for (const auto& [frame, joint] : n.left_samples)
        left.push_back({frame, names[std::size_t(joint)]});
      per_clip.push_back(
          {{"clip", r.clips[k].name},
           {"psnr_db", r.noisy_scores[c][k].psnr()},
           {"psnr_db_unglitched", json_number(r.noisy_scores[c][k].unglitched_psnr())},
           {"mpjpe_mm", json_number(r.noisy_scores[c][k].mpjpe_mm())},
           {"jitter_mm", json_number(r.noisy_scores[c][k].jitter_mm())},
           {"pops_found", n.pops},
           {"samples", r.clips[k].clean.rotations.size() / 4},
           {"popped", n.popped},
           {"pops_caught", n.pops_caught},
           {"pops_left", n.pops_left},
           {"pops_left_samples", left},
           {"popped_on_lone_frames", n.popped_lone},
           {"pops_left_on_lone_frames", n.pops_left_lone},
           {"false_repairs", n.false_repairs},
           {"garbage_joints", garbage}});
    }
    cj["noisy_per_clip"] = per_clip;
    conditions.push_back(cj);
  }
  j["conditions"] = conditions;

  nlohmann::json methods = nlohmann::json::array();
  for (std::size_t m = 0; m < config.grids.size(); ++m) {
    const MethodGrid& grid = config.grids[m];
    nlohmann::json mj{{"method", label(grid)},
                      {"repaired", grid.repaired},
                      {"lock_feet", grid.lock_feet},
                      {"automatic_rule", automatic_rule(grid.method)}};
    nlohmann::json grid_json = nlohmann::json::array();
    for (std::size_t p = 0; p <= grid.points.size(); ++p) {
      nlohmann::json per_condition = nlohmann::json::array();
      for (std::size_t c = 0; c < config.conditions.size(); ++c) {
        nlohmann::json cj = score_json(pooled(r, m, p, c));
        nlohmann::json per_clip = nlohmann::json::array();
        for (std::size_t k = 0; k < r.clips.size(); ++k) {
          const TaskResult& t = r.results[m][p][c][k];
          nlohmann::json kj = score_json(t.score);
          kj["clip"] = r.clips[k].name;
          if (!t.error.empty()) kj["error"] = t.error;
          if (p == grid.points.size()) kj["resolved"] = t.resolved;
          per_clip.push_back(kj);
        }
        cj["clips"] = per_clip;
        const Spread spread = psnr_spread(r, m, p, c);
        cj["psnr_db_per_clip"] = {{"min", json_number(spread.min)},
                                  {"median", json_number(spread.median)},
                                  {"max", json_number(spread.max)}};
        per_condition.push_back(cj);
      }
      if (p < grid.points.size())
        grid_json.push_back({{"params", point_json(grid.points[p])}, {"results", per_condition}});
      else
        mj["automatic"] = {{"results", per_condition}};
    }
    mj["grid"] = grid_json;
    nlohmann::json best = nlohmann::json::array();
    for (std::size_t c = 0; c < config.conditions.size(); ++c)
      best.push_back(best_point(r, config, m, c));
    mj["best_point"] = best;
    nlohmann::json edges = nlohmann::json::array();
    for (const auto& b : best)
      edges.push_back(b.get<int>() < 0 ? std::vector<std::string>{}
                                       : edge_parameters(grid, std::size_t(b.get<int>())));
    mj["best_point_edge_parameters"] = edges;
    methods.push_back(mj);
  }
  j["methods"] = methods;
  return j;
}

std::string html_report(const EvalResults& r, const EvalConfig& config,
                        const std::vector<Figure>& figures, const std::string& command_line) {
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<title>mocap-clean eval</title>\n<style>\n"
      "body{font-family:Helvetica,Arial,sans-serif;margin:24px;max-width:1300px;color:#222}\n"
      "table{border-collapse:collapse;margin:10px 0 24px}\n"
      "caption{text-align:left;font-weight:bold;padding:4px 0}\n"
      "th,td{border:1px solid #ccc;padding:4px 10px;font-size:13px}\n"
      "td{text-align:right;font-variant-numeric:tabular-nums}\n"
      "th{background:#f3f3f3;text-align:left}\n"
      "figure{display:inline-block;margin:8px}\nfigcaption{font-size:13px;max-width:640px}\n"
      "code{background:#f5f5f5;padding:2px 4px}\n</style>\n</head>\n<body>\n"
      "<h1>mocap-clean eval</h1>\n";
  std::size_t frames = total_frames(r);
  html += fmt::format(
      "<p>{} clips, {} frames; {} noise conditions; {} methods; seed {}; {} tasks filtered in "
      "{:.1f} s. Each cell: <b>best grid point / automatic parameters</b> (pooled over all "
      "clips).</p>\n<p><code>{}</code></p>\n",
      r.clips.size(), frames, config.conditions.size(), config.grids.size(), config.seed, r.tasks,
      r.filter_seconds, escape_xml(command_line));
  const std::vector<Table> tables = all_tables(r, config);
  html += to_html(tables.front());
  html += to_html(spread_table(r, config));
  html += "<h2>Figures</h2>\n";
  for (const Figure& f : figures)
    html += fmt::format("<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>\n",
                        f.file, escape_xml(f.caption), escape_xml(f.caption));
  html += "<h2>More scores</h2>\n";
  for (std::size_t i = 1; i < tables.size(); ++i) html += to_html(tables[i]);
  for (const Table& t : feet_tables(r, config)) html += to_html(t);
  html +=
      "<h2>Clips</h2>\n<table>\n<tr><th>clip</th><th>frames</th><th>impossible steps "
      "(frame: joint, rad)</th><th>segments</th><th>cm per unit</th></tr>\n";
  for (const EvalClip& c : r.clips) {
    std::string steps;
    for (const ImpossibleStep& s : c.steps)
      steps += fmt::format("{}{}: {} {:.2f}", steps.empty() ? "" : "; ", s.frame,
                           c.clean.skeleton->joint_names[std::size_t(s.joint)], s.angle);
    html += fmt::format(
        "<tr><th>{}</th><td>{}</td><td style=\"text-align:left\">{}</td><td>{}</td><td>{:.3g}{}"
        "</td></tr>\n",
        escape_xml(c.name), c.clean.frames, escape_xml(steps.empty() ? "none" : steps),
        c.segments.size(), c.geometry.unit_cm, c.geometry.unit_guessed ? " (guessed)" : "");
  }
  html += "</table>\n<h2>Automatic parameters</h2>\n<ul>\n";
  for (const MethodGrid& g : config.grids)
    html +=
        fmt::format("<li><b>{}</b>: {}{}</li>\n", label(g), escape_xml(automatic_rule(g.method)),
                    g.method.automatic() && config.guard
                        ? "; then clean's guard: a clip whose jitter or skating rose above "
                          "the noisy input's falls back toward it (eval --guard off: without)"
                        : "");
  html +=
      "</ul>\n<p>Everything, per clip and per grid point: <a href=\"report.json\">report.json</a>; "
      "the tables as markdown: <a href=\"table.md\">table.md</a>.</p>\n</body>\n</html>\n";
  return html;
}

}  // namespace mocap::engine::eval
