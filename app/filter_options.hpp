#pragma once
// The filter parameters of the spec as command-line options, shared by clean, filter and eval.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "app/cli_checks.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/run/run_options.hpp"

namespace mocap::engine {

struct FilterOptions {
  std::string method = "none";
  // Empty: the method's default (auto for --method auto, else off).
  std::string kernel = "gaussian", boundary = "mirror", space = "tangent", translations = "filter";
  std::string pops, garbage_joints = "keep", nlpm_range = "off", translation_sigma_t = "auto";
  std::string feet;   // empty: lock for --method auto, else off
  std::string guard;  // empty: on for --method auto, else off
  double sigma_t = 1.0, sigma_g = 0.2, h = 0, cutoff = 6.0, sigma_p = 0, kalman_lambda = 0;
  int window = 0, iterations = 5, search_radius = 10, patch_radius = 5, order = 2, passes = 5;
  int shard_joints = 8, shard_frames = 256;
  // --split-impossible / --no-split-impossible; neither: on with --method auto only.
  bool split_impossible_on = false, split_impossible_off = false;

  // Registers the options on `command`; `default_method` is shown in --help.
  void add_to(CLI::App& command, const std::string& default_method);
  // The settings the options describe (valid names are enforced by CLI11 already).
  FilterSettings settings() const;
  // Values that parse but are almost surely a mistake (degrees given as radians), to print.
  std::vector<std::string> warnings() const;
};

// The options of every command that runs the engine (--threads, --json, --no-progress).
void add_run_options(CLI::App& command, RunOptions& run);

}  // namespace mocap::engine
