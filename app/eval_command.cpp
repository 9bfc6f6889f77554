#include "app/eval_command.hpp"
#include "app/run_in_process.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <optional>

#include "app/cli_checks.hpp"
#include "engine/clip/methods.hpp"
#include "engine/eval/eval_plots.hpp"
#include "engine/eval/eval_report.hpp"
#include "engine/eval/eval_run.hpp"
#include "engine/run/atomic_file.hpp"
#include "engine/run/clip_source.hpp"
#include "engine/run/progress.hpp"
#include "engine/run/sources.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;
using namespace eval;

namespace {

int usage_error(const std::string& message) {
  fmt::print(stderr, "mocap-clean: eval: {}\n", message);
  return 2;
}

bool is_library_file(const std::string& argument) {
  std::error_code ec;
  if (!fs::is_regular_file(argument, ec)) return false;
  std::string ext = fs::path(argument).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".h5" || ext == ".hdf5";
}

// Reads every clip of `source`, naming failures on stderr.
void read_all(ClipSource& source, const EvalConfig& config, int frame_step,
              std::vector<EvalClip>& clips, std::size_t* failed) {
  for (std::size_t i = 0; i < source.count(); ++i) {
    std::string error;
    std::optional<Clip> clip = source.read(i, &error);
    if (!clip) {
      fmt::print(stderr, "mocap-clean: eval: {}\n", error);
      ++*failed;
      continue;
    }
    clips.push_back(prepare_clip(source.clip_path(i), std::move(*clip), config, frame_step));
  }
}

std::string quote(const std::string& s) {
  if (!s.empty() && s.find_first_of(" '\"\\$`") == std::string::npos) return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// The command that reproduces this run, with every setting spelled out.
std::string canonical_command(const EvalCommand& c, const EvalConfig& config) {
  std::string s = "mocap-clean eval";
  for (const auto& src : c.sources) s += " " + quote(src);
  s += " -o " + quote(c.output_dir);
  for (const auto& n : c.noise) s += " --noise " + quote(n);
  s += " --methods " + c.methods;
  s += " --pops " + c.pops;
  if (c.pop_stage != "auto") s += " --pop-stage " + c.pop_stage;
  if (c.feet != "off") s += " --feet " + c.feet;
  for (const auto& g : c.grid) s += " --grid " + quote(g);
  s += fmt::format(" --seed {}", config.seed);
  if (c.unit_cm > 0) s += fmt::format(" --unit-cm {:g}", c.unit_cm);
  if (!c.split_impossible) s += " --no-split-impossible";
  if (c.split_max_speed != 150) s += fmt::format(" --split-max-speed {:g}", c.split_max_speed);
  if (c.frame_step > 1) s += fmt::format(" --frame-step {}", c.frame_step);
  if (!c.plots) s += " --no-plots";
  return s;
}

}  // namespace

CLI::App* add_eval_subcommand(CLI::App& app, EvalCommand& command) {
  CLI::App* cmd = app.add_subcommand(
      "eval", "rerun the papers' experiments: add noise, filter, score, report (HTML, JSON, SVG)");
  cmd->add_option("SRC", command.sources, "BVH files, folders (searched recursively) or a library")
      ->required();
  cmd->add_option("-o,--output", command.output_dir,
                  "report folder: index.html, report.json, table.md, fig_*.svg")
      ->required();
  cmd->add_option("--noise", command.noise,
                  "noise conditions, repeatable: gaussian:S1,S2,... (rad) or impulse[:RATE[,MIN,"
                  "MAX]]\n(default: gaussian:0.008,0.03,0.12 and impulse)")
      ->group("Evaluation");
  // Every method of the table by default; the help names them, wrapped as CLI11 does not.
  if (command.methods.empty()) command.methods = all_eval_methods();
  std::string help = "comma-separated:";
  std::size_t line = help.size();
  for (const EvalVariant& v : eval_variants()) {
    std::string item(v.name);
    if (!v.note.empty()) item += " (" + std::string(v.note) + ")";
    item += &v == &eval_variants().back() ? "" : ",";
    if (line + 1 + item.size() > 72) {
      help += "\n";
      line = 0;
    } else {
      help += " ";
      ++line;
    }
    help += item;
    line += item.size();
  }
  cmd->add_option("--methods", command.methods, help)->capture_default_str()->group("Evaluation");
  cmd->add_option("--pops", command.pops,
                  "off: each method is the spec's filter on the noisy clip; on: after the "
                  "engine's default pop stage, --pops auto (rows METHOD+pops; garbage joints "
                  "kept); both")
      ->check(CLI::IsMember({"off", "on", "both"}))
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option("--pop-stage", command.pop_stage,
                  "the pop stage of the +pops rows and of auto: auto (clean's default: repairs "
                  "at 60 fps and more; from 20 fps, only clips with at least 0.4 % of their "
                  "samples flagged) or repair (repairs at every frame "
                  "rate, below 60 fps with the skeleton test, as clean --pops repair)")
      ->check(CLI::IsMember({"auto", "repair"}))
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option("--feet", command.feet,
                  "foot locking after the filter (as clean --feet lock): off; lock, on every "
                  "run; both, rows METHOD+feet beside each method (its automatic parameters, "
                  "then locking), with per-clip feet tables")
      ->check(CLI::IsMember({"off", "lock", "both"}))
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option("--guard", command.guard,
                  "auto's runs end with clean's guard (a clip whose jitter or skating came out "
                  "above the noisy input's, or its pop-repaired copy's, falls back to the input): "
                  "on, as clean runs it; off, the filter (and the lock) alone")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option(
         "--grid", command.grid,
         "replace one axis of a method's grid, repeatable: METHOD.PARAM=v1,v2,...\n"
         "bof: sigma_g|sigma_g_factor (+sigma_g_floor), sigma_t|sigma_t_factor, iterations;\n"
         "nlpm: h|h_factor, K, P; nlpm-robust: h|h_factor, range_factor, K, P;\n"
         "gaussian: sigma_t; butterworth: cutoff, order;\n"
         "moving-mean: passes; kalman: lambda|lambda_scale\n"
         "(factors: x sigma_hat; kalman's lambda_scale is c in c (120 frame_time)^2.5 / "
         "sigma_hat^3, automatic 1.1e-6)")
      ->group("Evaluation");
  cmd->add_option("--seed", command.seed, "noise seed (per clip and condition from it)")
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option("--unit-cm", command.unit_cm,
                  "cm per file length unit (default: guessed per clip: CMU-like 5.64, else 1)")
      ->check(kNonNegative)
      ->group("Evaluation");
  cmd->add_flag("--split-impossible,!--no-split-impossible", command.split_impossible,
                "filter and score separately the segments between physically impossible steps "
                "(e.g. CMU's synthetic T-pose frame 0); on by default")
      ->group("Evaluation");
  cmd->add_option("--split-max-speed", command.split_max_speed,
                  "a joint turning faster than this (rad/s) in one step is impossible (so is a "
                  "whole-body jump: the joints' mean turn over max(0.2 rad, 4.5 rad/s x frame "
                  "time))")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_option("--frame-step", command.frame_step,
                  "keep every N-th frame of each clip (4: 120 fps clips become 30 fps)")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Evaluation");
  cmd->add_flag("!--no-plots", command.plots, "skip the figures (and the runs they need)")
      ->group("Evaluation");
  add_run_options(*cmd, command.run);
  cmd->footer(
      "Examples:\n  mocap-clean eval mocap/ -o eval-report\n"
      "  mocap-clean eval mocap/ -o calib --methods bof,nlpm --grid bof.sigma_g=0.05,0.1,0.2\n"
      "  mocap-clean eval lib.h5 -o report --noise gaussian:0.03 --frame-step 4 --no-plots\n"
      "Each cell of the table: PSNR (dB) of the best grid point / of the automatic parameters,\n"
      "pooled over all clips. See docs/eval.md.");
  return cmd;
}

std::string all_eval_methods() {
  std::string names;
  for (const EvalVariant& v : eval_variants())
    names += (names.empty() ? "" : ",") + std::string(v.name);
  return names;
}

int run_eval(const EvalCommand& command) {
  const auto start = std::chrono::steady_clock::now();
  EvalConfig config;
  config.seed = command.seed;
  config.unit_cm = command.unit_cm;
  config.split_impossible = command.split_impossible;
  config.split.max_speed = command.split_max_speed;
  if (const Status s = config.split.validate(); !s) return usage_error(s.message());

  std::string error;
  if (command.noise.empty()) config.conditions = default_noise_conditions();
  for (const std::string& spec : command.noise) {
    const auto parsed = parse_noise(spec, &error);
    if (parsed.empty()) return usage_error(error);
    config.conditions.insert(config.conditions.end(), parsed.begin(), parsed.end());
  }
  std::vector<EvalMethod> methods;
  const std::string names = command.methods.empty() ? all_eval_methods() : command.methods;
  for (std::size_t pos = 0; pos <= names.size();) {
    const std::size_t comma = std::min(names.find(',', pos), names.size());
    const std::string name = names.substr(pos, comma - pos);
    const auto m = parse_eval_method(name);
    if (!m) return usage_error("unknown method '" + name + "' in --methods");
    if (std::find(methods.begin(), methods.end(), *m) == methods.end()) methods.push_back(*m);
    pos = comma + 1;
  }
  std::vector<GridOverride> overrides;
  for (const std::string& spec : command.grid) {
    const auto g = parse_grid_override(spec, &error);
    if (!g) return usage_error(error);
    if (std::find(methods.begin(), methods.end(), g->method) == methods.end())
      return usage_error("--grid " + spec + ": " + std::string(to_string(g->method)) +
                         " is not in --methods");
    overrides.push_back(*g);
  }
  config.grids = build_grids(methods, overrides, command.pops != "on", command.pops != "off");
  apply_feet_mode(config.grids, command.feet);
  config.guard = command.guard == "on";
  config.pop_stage = command.pop_stage == "repair" ? PopsMode::repair : PopsMode::automatic;
  config.lock_feet = std::any_of(config.grids.begin(), config.grids.end(),
                                 [](const MethodGrid& g) { return g.lock_feet; });
  config.repaired = std::any_of(config.grids.begin(), config.grids.end(),
                                [](const MethodGrid& g) { return g.repaired; });

  const ThreadLimit limit(command.run.threads);
  const int threads = ThreadLimit::active();

  // Sources: library files, then BVH files and folders.
  std::vector<std::string> bvh_arguments;
  std::vector<EvalClip> clips;
  std::size_t failed = 0;
  for (const std::string& src : command.sources) {
    if (!is_library_file(src)) {
      bvh_arguments.push_back(src);
      continue;
    }
    auto library = LibrarySource::open(src, &error);
    if (!library) return usage_error(error);
    read_all(*library, config, command.frame_step, clips, &failed);
  }
  if (!bvh_arguments.empty()) {
    const SourceList list = collect_bvh_sources(bvh_arguments);
    for (const auto& e : list.errors) fmt::print(stderr, "mocap-clean: eval: {}\n", e);
    if (!list.errors.empty()) return 2;
    BvhSource bvh(list.files);
    read_all(bvh, config, command.frame_step, clips, &failed);
  }
  if (clips.empty()) return usage_error("no clip could be read from the given sources");

  std::error_code ec;
  const fs::path dir(command.output_dir);
  fs::create_directories(dir, ec);
  if (ec) return usage_error("cannot create " + dir.string() + ": " + ec.message());

  const bool show_progress =
      command.run.progress && !command.run.json && Progress::stderr_is_terminal();
  const EvalResults results =
      run_evaluation(std::move(clips), config, [&](std::size_t done, std::size_t total) {
        if (show_progress && (done % 16 == 0 || done == total))
          fmt::print(stderr, "\reval: {}/{} runs{}", done, total, done == total ? "\n" : "");
      });

  // Each grid point that could not run is named once (a cut-off above a 30 fps clip's Nyquist
  // fails on every clip and condition alike), with its first reason and how often it failed.
  for (std::size_t m = 0; m < results.results.size(); ++m)
    for (std::size_t p = 0; p < results.results[m].size(); ++p) {
      std::size_t failures = 0, runs = 0;
      std::string first;
      for (const auto& condition : results.results[m][p])
        for (std::size_t k = 0; k < condition.size(); ++k) {
          ++runs;
          if (condition[k].error.empty()) continue;
          if (failures++ == 0) first = results.clips[k].name + ": " + condition[k].error;
        }
      if (failures == 0) continue;
      const auto& points = config.grids[m].points;
      fmt::print(stderr, "mocap-clean: eval: {} {}: failed on {} of {} runs, left out ({})\n",
                 label(config.grids[m]),
                 p < points.size() ? describe(points[p]) : std::string("automatic"), failures, runs,
                 first);
    }

  std::vector<Figure> figures;
  if (command.plots && !write_figures(results, config, dir, &figures, &error))
    return usage_error(error);
  const std::string command_line = canonical_command(command, config);
  nlohmann::json report = report_json(results, config);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report["command_line"] = command_line;
  report["threads"] = threads;
  report["timing"]["total_seconds"] = seconds;
  const std::string tables = markdown_report(results, config);
  if (!write_file_atomically(dir / "report.json", report.dump(1) + "\n", &error) ||
      !write_file_atomically(dir / "table.md", tables, &error) ||
      !write_file_atomically(dir / "index.html",
                             html_report(results, config, figures, command_line), &error))
    return usage_error(error);

  std::size_t frames = 0;
  for (const EvalClip& c : results.clips) frames += std::size_t(c.clean.frames);
  if (command.run.json) {
    nlohmann::json summary{{"command", "eval"},
                           {"output", command.output_dir},
                           {"clips", results.clips.size()},
                           {"failed_clips", failed},
                           {"frames", frames},
                           {"tasks", results.tasks},
                           {"threads", threads},
                           {"seconds", seconds}};
    nlohmann::json cells = nlohmann::json::array();
    for (const auto& m : report["methods"])
      for (std::size_t c = 0; c < config.conditions.size(); ++c) {
        const int best = m["best_point"][c].get<int>();
        cells.push_back(
            {{"method", m["method"]},
             {"condition", config.conditions[c].label()},
             {"best_psnr_db", best < 0 ? nlohmann::json(nullptr)
                                       : m["grid"][std::size_t(best)]["results"][c]["psnr_db"]},
             {"best_params",
              best < 0 ? nlohmann::json(nullptr) : m["grid"][std::size_t(best)]["params"]},
             {"auto_psnr_db", m["automatic"]["results"][c]["psnr_db"]}});
      }
    summary["table"] = cells;
    fmt::print("{}\n", summary.dump());
  } else {
    fmt::print("{}\n", psnr_table(results, config));
    fmt::print(stderr,
               "eval: {} clips, {} frames, {} runs on {} threads in {:.1f} s; report in {}\n",
               results.clips.size(), frames, results.tasks, threads, seconds,
               (dir / "index.html").string());
  }
  return failed > 0 ? 1 : 0;
}

}  // namespace mocap::engine
