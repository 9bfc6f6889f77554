#pragma once
// The filter parameters of the spec as command-line options, shared by clean, filter and eval.
#include <CLI/CLI.hpp>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "app/cli_checks.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/run/run_options.hpp"

namespace mocap::engine {

struct FilterOptions {
  FilterOptions();  // the methods' parameters at their defaults
  std::string method = "none";
  std::string translations = "filter";
  // Empty: the method's default (auto for --method auto, else off).
  std::string pops, garbage_joints = "keep";
  std::string feet;   // empty: lock for --method auto, else off
  std::string guard;  // empty: on for --method auto, else off
  int shard_joints = 8, shard_frames = 256;
  // The methods' own options (engine/clip/methods.hpp, MethodEntry::options), by long name
  // without the dashes ("sigma-t"): one map per type, so CLI11 writes into them.
  std::map<std::string, double, std::less<>> numbers;
  std::map<std::string, int, std::less<>> integers;
  std::map<std::string, std::string, std::less<>> words;
  // --split-impossible / --no-split-impossible; neither: on with --method auto only.
  bool split_impossible_on = false, split_impossible_off = false;

  // Registers the options on `command`; `default_method` is shown in --help.
  void add_to(CLI::App& command, const std::string& default_method);
  // The settings the options describe (valid names are enforced by CLI11 already).
  FilterSettings settings() const;
  // Values that parse but are almost surely a mistake (degrees given as radians), to print.
  std::vector<std::string> warnings() const;
  // A method option's value (its default until parsed): numbers.at("sigma-t") and so on.
  double number(std::string_view name) const;
  int integer(std::string_view name) const;
  const std::string& word(std::string_view name) const;
};

// The options of every command that runs the engine (--threads, --json, --no-progress).
void add_run_options(CLI::App& command, RunOptions& run);

}  // namespace mocap::engine
