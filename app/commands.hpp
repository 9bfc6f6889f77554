#pragma once
// The subcommands of mocap-clean, each a function of its parsed options.
#include <string>
#include <vector>

#include "app/filter_options.hpp"
#include "engine/run/run_summary.hpp"
#include "engine/run/sources.hpp"

namespace mocap::engine {

struct CleanCommand {
  std::vector<std::string> sources;
  std::string output_dir;  // a folder, or a file ending in .bvh when there is one source file
  bool resume = false;     // keep the outputs an earlier run with the same parameters finished
  bool overwrite = false;  // write into a folder that already holds files
  std::string report_dir;  // --report: the review page (engine/run/review_report.hpp)
  FilterOptions filter;
  RunOptions run;
};
int run_clean(const CleanCommand& command);

// BVH files in, filtered BVH files out (same relative layout): the engine behind `clean`.
RunSummary clean_files(const std::vector<SourceFile>& files, const std::string& output_dir,
                       const FilterSettings& settings, const RunOptions& run);

struct DemoCommand {
  std::string output_dir = "mocap-clean-demo";
  FilterOptions filter;
  RunOptions run;
  double noise_sigma = 0.03;
  unsigned long long seed = 1;
};
int run_demo(const DemoCommand& command);

// The output of the library commands (import, filter, noise).
struct LibraryOutput {
  std::string path;
  std::string compression = "lz4";
  bool resume = false;
  bool checksum = true;  // --checksum / --no-checksum: Fletcher-32 on every chunk
  int clips_per_part = 256;
  std::string shard = "0/1";  // --shard I/N
  void add_to(CLI::App& command);
};

struct ImportCommand {
  std::vector<std::string> sources;
  LibraryOutput output;
  RunOptions run;
};
int run_import(const ImportCommand& command);

struct FilterCommand {
  std::string input;
  LibraryOutput output;
  std::string report_dir;  // --report: the review page (engine/run/review_report.hpp)
  FilterOptions filter;
  RunOptions run;
};
int run_filter(const FilterCommand& command);

struct ExportCommand {
  std::string input;
  std::string output_dir;
  RunOptions run;
};
int run_export(const ExportCommand& command);

struct NoiseCommand {
  std::string input;
  LibraryOutput output;
  std::string model = "gaussian";
  double sigma = 0.03, rate = 0.01, min_angle = 0.3, max_angle = 1.0;
  double position_sigma = 0;  // fraction of each clip's body height; 0: positions untouched
  unsigned long long seed = 1;
  RunOptions run;
};
int run_noise(const NoiseCommand& command);

struct JoinCommand {
  std::vector<std::string> parts;  // part files or folders of them
  std::string output;
};
int run_join(const JoinCommand& command);

struct InfoCommand {
  std::string input;
  bool json = false;
  bool list_clips = false;
  bool joints = false;  // --joints: read every clip and name its garbage joints
  bool check = false;   // --check: read and validate every clip (io/clip_validation.hpp)
};
int run_info(const InfoCommand& command);
// info on one BVH file (run_info hands over when the file's name ends in .bvh).
int run_info_bvh(const InfoCommand& command);

}  // namespace mocap::engine
