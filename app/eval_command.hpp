#pragma once
// `mocap-clean eval SRC... -o REPORT_DIR`: the papers' experiments rerun on any library. Adds
// seeded noise to every clip, runs each method over a parameter grid and with its automatic
// parameters, scores against the clean clip, and writes report.json, table.md, index.html and
// SVG figures; prints the PSNR table (Dean & Lewis 2017, Table I style) on stdout.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "app/filter_options.hpp"

namespace mocap::engine {

struct EvalCommand {
  std::vector<std::string> sources;  // BVH files, folders, or library files (.h5)
  std::string output_dir;
  std::vector<std::string> noise;  // --noise specs; empty = the defaults
  std::string methods;             // empty: every method of the table (engine/clip/methods.hpp)
  std::string pops = "both";       // off: the spec filters; on: after the pop stage; both
  std::string pop_stage = "auto";  // the stage of the +pops rows and auto: auto or repair
  std::string feet = "off";        // off, lock, both (eval_spec.hpp, apply_feet_mode)
  std::string guard = "on";        // auto's runs end with the engine's guard, as clean's do
  std::vector<std::string> grid;   // --grid METHOD.PARAM=v1,v2
  unsigned long long seed = 1;
  double unit_cm = 0;  // 0 = guess per clip
  bool split_impossible = true;
  double split_max_speed = 150;
  bool plots = true;
  int frame_step = 1;  // --frame-step: every N-th frame (a lower frame rate)
  RunOptions run;
  std::string command_line;  // as typed, for the report
};

// Registers the `eval` subcommand and its options on `app`.
CLI::App* add_eval_subcommand(CLI::App& app, EvalCommand& command);
int run_eval(const EvalCommand& command);
// Every eval method of the table (engine/clip/methods.hpp), comma-separated: --methods' default.
std::string all_eval_methods();

}  // namespace mocap::engine
