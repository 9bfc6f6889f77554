// `mocap-clean clean`: BVH files in, filtered BVH files out, through the same task graph as the
// library commands.
#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>

#include "app/commands.hpp"
#include "app/report.hpp"
#include "app/run_in_process.hpp"
#include "core/version.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/run/automatic_tally.hpp"
#include "engine/run/job.hpp"
#include "engine/run/review_report.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

namespace {

// One JSON line per output file, appended once the file is renamed into place: a file without
// its line (killed between the two) or with a line cut short is redone by --resume, never kept.
constexpr const char* kManifestName = ".mocap-clean.jsonl";

bool names_bvh_file(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".bvh";
}

// The last record of each output file (a later run replaced the earlier one's file).
std::map<std::string, nlohmann::json> read_manifest(const fs::path& path) {
  std::map<std::string, nlohmann::json> records;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    nlohmann::json record = nlohmann::json::parse(line, nullptr, false);
    if (!record.is_object() || !record.contains("file") || !record["file"].is_string()) continue;
    // The key first: json's assignment takes its operand by value, moving it out beforehand.
    const std::string file = record["file"].get<std::string>();
    records[file] = std::move(record);
  }
  return records;
}

// An output --resume keeps: written whole (rename) and recorded by a run of this engine version
// with the same parameters, and newer than its input (an input edited since is cleaned again).
bool is_complete(const SourceFile& source, const fs::path& output_folder,
                 const std::map<std::string, nlohmann::json>& records,
                 const nlohmann::json& parameters) {
  const auto it = records.find(source.relative);
  if (it == records.end()) return false;
  const nlohmann::json& r = it->second;
  if (r.value("engine_version", "") != kVersion || !r.contains("parameters") ||
      r["parameters"] != parameters)
    return false;
  std::error_code ec;
  const auto output_time = fs::last_write_time(output_folder / source.relative, ec);
  if (ec) return false;
  const auto input_time = fs::last_write_time(source.path, ec);
  return !ec && output_time > input_time;
}

// The BVH folder sink, appending each written file's record to the manifest.
class RecordingSink final : public ClipSink {
 public:
  RecordingSink(fs::path folder, std::FILE* manifest, nlohmann::json parameters,
                std::map<std::string, std::string> inputs)
      : inner_(std::move(folder)),
        manifest_(manifest),
        parameters_(std::move(parameters)),
        inputs_(std::move(inputs)) {}
  bool prepare(const Clip& clip, std::any& prepared, std::string* error) override {
    return inner_.prepare(clip, prepared, error);
  }
  bool write(const std::string& clip_path, const std::string& relative, std::any& prepared,
             std::string* error) override {
    if (!inner_.write(clip_path, relative, prepared, error)) return false;
    const nlohmann::json record = {{"file", relative},
                                   {"input", inputs_[relative]},
                                   {"engine_version", kVersion},
                                   {"parameters", parameters_}};
    const std::string line = record.dump() + "\n";
    if (std::fwrite(line.data(), 1, line.size(), manifest_) != line.size() ||
        std::fflush(manifest_) != 0) {
      if (error) *error = fmt::format("cannot record it in {}: {}", kManifestName, strerror(errno));
      return false;
    }
    return true;
  }

 private:
  BvhFolderSink inner_;
  std::FILE* manifest_;
  nlohmann::json parameters_;
  std::map<std::string, std::string> inputs_;
};

int usage_error(const std::string& message) {
  fmt::print(stderr, "mocap-clean: clean: {}\n", message);
  return 2;
}

}  // namespace

RunSummary clean_files(const std::vector<SourceFile>& files, const std::string& output_dir,
                       const FilterSettings& settings, const RunOptions& run) {
  BvhSource source(files, /*keep_source_angles=*/true);
  BvhFolderSink sink(output_dir);
  Job job;
  job.label = "clean";
  job.source = &source;
  job.sink = &sink;
  job.filter = settings;
  job.run = run;
  RunSummary summary = run_in_process(job);
  summary.extra["method"] = std::string(to_string(settings.method));
  summary.extra["parameters"] = settings.to_json();
  return summary;
}

int run_clean(const CleanCommand& command) {
  std::error_code ec;
  // `-o out.bvh` with one source file writes that file; a folder named out.bvh stays a folder.
  const bool single_file =
      names_bvh_file(command.output_dir) && !fs::is_directory(command.output_dir, ec);
  // The output folder may sit inside a source folder, or be one: an earlier run's output is not
  // input, and no input is overwritten.
  SourceList sources =
      collect_bvh_sources(command.sources, single_file ? fs::path{} : fs::path(command.output_dir));
  for (const auto& e : sources.errors) fmt::print(stderr, "mocap-clean: clean: {}\n", e);
  if (!sources.errors.empty()) return 2;
  if (sources.files.empty()) return usage_error("no .bvh files found in the given sources");
  fs::path output_folder = command.output_dir;
  if (single_file) {
    if (sources.files.size() != 1)
      return usage_error(fmt::format(
          "-o {} names one BVH file, but the sources hold {} files; give a folder to -o",
          command.output_dir, sources.files.size()));
    const fs::path target(command.output_dir);
    if (fs::weakly_canonical(target, ec) == fs::weakly_canonical(sources.files[0].path, ec))
      return usage_error(sources.files[0].path.string() +
                         ": the output would overwrite this input; choose another -o");
    output_folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    sources.files[0].relative = target.filename().string();
    if (fs::exists(target, ec) && !command.resume && !command.overwrite)
      return usage_error(command.output_dir +
                         " exists; pass --overwrite to replace it (or --resume to keep it when "
                         "an earlier run with the same parameters wrote it)");
  } else if (fs::is_directory(output_folder, ec) && !fs::is_empty(output_folder, ec) &&
             !command.resume && !command.overwrite) {
    return usage_error(
        command.output_dir +
        " is not empty; pass --resume to finish an interrupted run (outputs written with the "
        "same parameters and newer than their input are kept), or --overwrite to replace its "
        "files");
  }
  const FilterSettings settings = command.filter.settings();
  if (const Status s = settings.validate(); !s.ok()) return usage_error(s.message());
  const nlohmann::json parameters = settings.to_json();
  Status report_error;
  const auto review = open_review_report(command.report_dir, "clean", &report_error);
  if (!report_error.ok()) return usage_error(report_error.message());

  std::vector<std::size_t> selection;
  const fs::path manifest_path = output_folder / kManifestName;
  const auto records =
      command.resume ? read_manifest(manifest_path) : std::map<std::string, nlohmann::json>{};
  std::map<std::string, std::string> inputs;
  for (std::size_t i = 0; i < sources.files.size(); ++i) {
    inputs[sources.files[i].relative] = sources.files[i].path.string();
    if (!command.resume || !is_complete(sources.files[i], output_folder, records, parameters))
      selection.push_back(i);
  }
  const std::size_t kept = sources.files.size() - selection.size();

  RunSummary summary;
  summary.command = "clean";
  if (!selection.empty()) {
    fs::create_directories(output_folder, ec);
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> manifest(
        std::fopen(manifest_path.c_str(), "ab"), &std::fclose);
    if (!manifest)
      return usage_error(
          fmt::format("cannot write {}: {}", manifest_path.string(), std::strerror(errno)));
    BvhSource source(sources.files, /*keep_source_angles=*/true);
    RecordingSink sink(output_folder, manifest.get(), parameters, std::move(inputs));
    Job job;
    job.label = "clean";
    job.source = &source;
    job.sink = &sink;
    job.selection = std::move(selection);
    job.filter = settings;
    job.run = command.run;
    job.review = review.get();
    summary = run_in_process(job);
  }
  summary.extra["method"] = std::string(to_string(settings.method));
  summary.extra["parameters"] = parameters;
  if (command.resume) {
    summary.extra["kept"] = kept;
    if (!command.run.json)
      fmt::print(stderr,
                 "clean: {} of {} outputs already complete (same parameters, newer than their "
                 "input): kept\n",
                 kept, sources.files.size());
  }
  report(summary, command.run.json);
  return close_review_report(review.get(), summary, summary.exit_status());
}

}  // namespace mocap::engine
