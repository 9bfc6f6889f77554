// The library commands: import (BVH -> library), filter (library -> library), export
// (library -> BVH), noise (library -> noisy library) and info.
#include <fmt/core.h>

#include <cctype>
#include <chrono>
#include <numeric>
#include <set>

#include "app/cli_checks.hpp"
#include "app/cluster.hpp"
#include "app/commands.hpp"
#include "app/report.hpp"
#include "app/run_in_process.hpp"
#include "core/version.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/library/shard_plan.hpp"
#include "engine/run/job.hpp"
#include "io/clip_validation.hpp"
#include "io/compression.hpp"
#include "io/library_join.hpp"
#include "io/library_reader.hpp"
#include "kernels/noise_model.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

namespace {

int usage_error(const std::string& command, const std::string& message) {
  fmt::print(stderr, "mocap-clean: {}: {}\n", command, message);
  return 2;
}

// Opens the crash-safe output of a library command, or explains why not.
std::unique_ptr<LibrarySink> open_library_sink(const LibraryOutput& out, const ShardSpec& shard,
                                               const io::Provenance& provenance,
                                               std::string* error) {
  const auto compression = io::parse_compression(out.compression);
  if (!compression) {
    *error = "unknown compression '" + out.compression + "'";
    return nullptr;
  }
  if (std::string why = io::compression_unavailable_reason(*compression); !why.empty()) {
    *error = why;
    return nullptr;
  }
  PartedOutputOptions options;
  options.output = out.path;
  options.compression = *compression;
  options.checksum = out.checksum;
  options.resume = out.resume;
  options.clips_per_part = out.clips_per_part;
  options.provenance = provenance;
  if (shard.active()) {
    options.shared_parts = true;
    options.tag = shard.tag();
  }
  auto parted = PartedOutput::open(options, error);
  if (!parted) return nullptr;
  auto sink = std::make_unique<LibrarySink>(std::move(parted));
  sink->compression = *compression;
  sink->checksum = out.checksum;
  return sink;
}

// The shard this process runs: --shard I/N, or under mpirun rank/size (the same split).
std::optional<ShardSpec> process_shard(const LibraryOutput& out, std::string* error) {
  auto shard = parse_shard(out.shard, error);
  if (!shard || !cluster().active()) return shard;
  if (shard->active()) {
    *error = "--shard and mpirun split the library the same way: use one of them";
    return std::nullopt;
  }
  return ShardSpec{cluster().rank, cluster().size};
}

// The indices among `candidates` whose clip paths the output does not hold yet.
std::vector<std::size_t> pending(const ClipSource& source,
                                 const std::vector<std::size_t>& candidates,
                                 const PartedOutput& output, std::size_t* skipped) {
  std::vector<std::size_t> todo;
  for (std::size_t i : candidates)
    if (!output.done().count(source.clip_path(i))) todo.push_back(i);
  *skipped = candidates.size() - todo.size();
  return todo;
}

// Runs `job` into the library sink, joins the parts, reports. Shared by import, filter, noise.
// With a shard, runs only that shard's clips; the last shard to finish joins.
int run_into_library(Job& job, LibrarySink& sink, const LibraryOutput& out, const ShardSpec& shard,
                     const io::Provenance& provenance, const std::string& command) {
  const auto start = std::chrono::steady_clock::now();
  if (cluster().rank != 0) job.run.progress = false;  // one progress bar, rank 0's
  // Split all clips, then drop the finished ones: shards that start at different moments of a
  // resumed run must agree on the split, so it cannot depend on what is finished already.
  std::vector<std::size_t> all(job.source->count());
  std::iota(all.begin(), all.end(), std::size_t(0));
  std::size_t skipped = 0;
  job.selection =
      pending(*job.source, shard_selection(*job.source, all, shard), sink.output(), &skipped);
  if (job.source->count() == 0) return usage_error(command, "the input holds no clips");
  if (skipped > 0 && !job.run.json)
    fmt::print(stderr, "{}: resuming: {} clips already done, {} to go{}\n", command, skipped,
               job.selection.size(), shard.active() ? " in this shard" : "");
  RunSummary summary = job.selection.empty() ? RunSummary{} : run_in_process(job);
  summary.command = command;
  summary.extra["output"] = out.path;
  summary.extra["resumed_clips"] = skipped;
  summary.extra["compression"] = out.compression;
  summary.extra["checksum"] = out.checksum;
  if (shard.active()) summary.extra["shard"] = fmt::format("{}/{}", shard.index, shard.count);
  std::string error;
  bool joined = false;
  if (summary.interrupted) {
    if (!sink.output().commit(&error)) summary.failed.push_back({out.path, error});
    fmt::print(stderr,
               "{}: interrupted: the clips finished so far are kept{}; run the same command with "
               "--resume to complete it\n",
               command, shard.active() ? "" : fmt::format(" ({} is valid)", out.path));
  } else if (cluster().active()) {
    // Every rank commits its parts; once all have, rank 0 joins them.
    if (!sink.output().mark_finished(&error)) summary.failed.push_back({out.path, error});
    cluster_barrier();
    if (cluster().rank == 0 && error.empty()) {
      if (!sink.output().join(provenance, &error)) summary.failed.push_back({out.path, error});
      joined = error.empty();
    }
  } else if (shard.active()) {
    if (!sink.output().mark_finished(&error)) {
      summary.failed.push_back({out.path, error});
    } else if (!sink.output().join_if_all_finished(shard.count, provenance, &joined, &error)) {
      summary.failed.push_back({out.path, error});
    } else if (!joined && !job.run.json) {
      fmt::print(stderr, "{}: shard {}/{} done; the last shard to finish joins {}\n", command,
                 shard.index, shard.count, out.path);
    }
  } else if (!sink.output().finish(provenance, &error)) {
    // Clips were processed and the committed ones are safe in OUT.parts: a failed join (a full
    // disk) is a failure of this run, exit 1, not a run that could not start.
    summary.failed.push_back({out.path, error});
  } else {
    joined = true;
  }
  // Clips whose part could not be written after they were counted (a full disk).
  for (auto& lost : sink.output().take_lost()) {
    summary.failed.push_back({lost.clip_path, lost.error});
    summary.clips -= std::min(summary.clips, std::size_t(1));
    summary.frames -= std::min(summary.frames, lost.frames);
    summary.joints -= std::min(summary.joints, lost.joints);
    summary.joint_frames -= std::min(summary.joint_frames, lost.frames * lost.joints);
  }
  summary.extra["joined"] = joined;
  // The whole command, joining the parts included.
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (cluster().active()) {
    const RunSummary total = cluster_gather(summary);
    if (cluster().rank != 0) return summary.exit_status();
    report(total, job.run.json);
    return total.exit_status();
  }
  report(summary, job.run.json);
  return summary.exit_status();
}

io::Provenance make_provenance(const std::string& method, const nlohmann::json& parameters,
                               const std::string& input) {
  return {method, parameters.dump(), std::string("mocap-clean ") + kVersion, input, ""};
}

// With --resume, an output that a finished run wrote from the same input library (not changed
// since), with the same command, parameters and engine, is complete: a job array or a script
// run again after it finished redoes nothing. (An interrupted run leaves OUT.parts/ instead.)
bool finished_before(const LibraryOutput& out, const io::Provenance& provenance) {
  std::error_code ec;
  if (!out.resume || !fs::is_regular_file(out.path, ec) || fs::exists(out.path + ".parts", ec))
    return false;
  const auto output_time = fs::last_write_time(out.path, ec);
  if (ec || fs::last_write_time(provenance.input_file, ec) > output_time || ec) return false;
  std::string error;
  const auto reader = io::LibraryReader::open(out.path, &error);
  const auto recorded = reader ? reader->provenance() : std::nullopt;
  return recorded && recorded->method == provenance.method &&
         recorded->parameters_json == provenance.parameters_json &&
         recorded->input_file == provenance.input_file &&
         recorded->engine_version == provenance.engine_version;
}

int report_finished_before(const std::string& command, const LibraryOutput& out,
                           const RunOptions& run) {
  if (cluster().rank != 0) return 0;
  if (run.json) {
    RunSummary summary;
    summary.command = command;
    summary.extra["output"] = out.path;
    summary.extra["already_complete"] = true;
    fmt::print("{}\n", summary.to_json().dump());
  } else {
    fmt::print(stderr,
               "{}: {} is already complete (same input, parameters and engine; the input has not "
               "changed since): nothing to do\n",
               command, out.path);
  }
  return 0;
}

}  // namespace

void LibraryOutput::add_to(CLI::App& cmd) {
  cmd.add_option("-o,--output", path, "the library file to write (HDF5)")->required();
  cmd.add_option("--compression", compression,
                 "chunk compression: lz4 (fast, needs the HDF5 LZ4 plugin to read), deflate "
                 "(smaller, slow to write), none")
      ->check(CLI::IsMember({"none", "lz4", "deflate"}))
      ->capture_default_str();
  cmd.add_flag("--resume", resume, "complete an interrupted run: keep the clips it finished");
  cmd.add_flag("--checksum,!--no-checksum", checksum,
               "HDF5 Fletcher-32 checksum on every chunk, verified on every read (default: on)");
  cmd.add_option(
         "--shard", shard,
         "I/N: process only the I-th of N cost-balanced shards (job arrays); the last shard "
         "to finish joins OUT")
      ->group("Cluster");
  cmd.add_option("--clips-per-part", clips_per_part, "clips per committed part file")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Engine");
}

int run_import(const ImportCommand& command) {
  const SourceList sources = collect_bvh_sources(command.sources);
  for (const auto& e : sources.errors) fmt::print(stderr, "mocap-clean: import: {}\n", e);
  if (!sources.errors.empty()) return 2;
  if (sources.files.empty())
    return usage_error("import", "no .bvh files found in the given sources");
  std::string error;
  const auto shard = process_shard(command.output, &error);
  if (!shard) return usage_error("import", error);
  std::string inputs;
  for (const auto& s : command.sources) inputs += (inputs.empty() ? "" : " ") + s;
  const io::Provenance provenance = make_provenance("import", nlohmann::json::object(), inputs);
  auto sink = open_library_sink(command.output, *shard, provenance, &error);
  if (!sink) return usage_error("import", error);
  BvhSource source(sources.files);
  Job job;
  job.label = "import";
  job.source = &source;
  job.sink = sink.get();
  job.run = command.run;
  return run_into_library(job, *sink, command.output, *shard, provenance, "import");
}

int run_filter(const FilterCommand& command) {
  const FilterSettings settings = command.filter.settings();
  if (const Status s = settings.validate(); !s.ok()) return usage_error("filter", s.message());
  std::string error;
  const auto shard = process_shard(command.output, &error);
  if (!shard) return usage_error("filter", error);
  auto source = LibrarySource::open(command.input, &error);
  if (!source) return usage_error("filter", error);
  const io::Provenance provenance =
      make_provenance(std::string(to_string(settings.method)), settings.to_json(), command.input);
  if (finished_before(command.output, provenance))
    return report_finished_before("filter", command.output, command.run);
  if (!command.report_dir.empty() && shard->active())
    return usage_error("filter",
                       "--report writes one page from one process: run it without "
                       "--shard or mpirun");
  Status report_error;
  const auto review = open_review_report(command.report_dir, "filter", &report_error);
  if (!report_error.ok()) return usage_error("filter", report_error.message());
  auto sink = open_library_sink(command.output, *shard, provenance, &error);
  if (!sink) return usage_error("filter", error);
  Job job;
  job.label = "filter";
  job.source = source.get();
  job.sink = sink.get();
  job.filter = settings;
  job.run = command.run;
  job.review = review.get();
  const auto start = std::chrono::steady_clock::now();
  const int status = run_into_library(job, *sink, command.output, *shard, provenance, "filter");
  RunSummary run;
  run.command = "filter";
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return close_review_report(review.get(), run, status);
}

int run_export(const ExportCommand& command) {
  std::string error;
  auto source = LibrarySource::open(command.input, &error);
  if (!source) return usage_error("export", error);
  BvhFolderSink sink(command.output_dir);
  Job job;
  job.label = "export";
  job.source = source.get();
  job.sink = &sink;
  job.run = command.run;
  const RunSummary summary = run_in_process(job);
  report(summary, command.run.json);
  return summary.exit_status();
}

namespace {

// A seed per clip from the run's seed and the clip's path: the noise of a clip does not depend
// on which other clips run, in which order, or on how many threads (splitmix64 of FNV-1a).
std::uint64_t clip_seed(std::uint64_t seed, const std::string& clip_path) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : clip_path) h = (h ^ c) * 1099511628211ull;
  std::uint64_t z = seed + h + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

}  // namespace

nlohmann::json noise_parameters(const NoiseCommand& command) {
  nlohmann::json parameters = {{"model", command.model}, {"seed", command.seed}};
  if (command.model == "gaussian") {
    parameters["sigma"] = command.sigma;
  } else {
    parameters["rate"] = command.rate;
    parameters["min_angle"] = command.min_angle;
    parameters["max_angle"] = command.max_angle;
  }
  if (command.position_sigma > 0)
    parameters["position_sigma_body_heights"] = command.position_sigma;
  return parameters;
}

int run_noise(const NoiseCommand& command) {
  std::string error;
  const auto shard = process_shard(command.output, &error);
  if (!shard) return usage_error("noise", error);
  auto source = LibrarySource::open(command.input, &error);
  if (!source) return usage_error("noise", error);
  const io::Provenance provenance =
      make_provenance("noise", noise_parameters(command), command.input);
  if (finished_before(command.output, provenance))
    return report_finished_before("noise", command.output, command.run);
  auto sink = open_library_sink(command.output, *shard, provenance, &error);
  if (!sink) return usage_error("noise", error);
  Job job;
  job.label = "noise";
  job.source = source.get();
  job.sink = sink.get();
  job.run = command.run;
  const ClipSource* src = source.get();
  job.transform = [&command, src](Clip& clip, std::size_t index) -> Status {
    const std::uint64_t seed = clip_seed(command.seed, src->clip_path(index));
    if (command.model == "gaussian") {
      add_noise(GaussianNoise{command.sigma, seed}, clip.rotation_span());
    } else {
      add_noise(ImpulseNoise{command.rate, command.min_angle, command.max_angle, seed},
                clip.rotation_span());
    }
    if (command.position_sigma > 0) {
      const double sigma = command.position_sigma * body_height(*clip.skeleton);
      add_noise(PositionNoise{sigma, position_noise_seed(seed)}, clip.translation_span(),
                clip.skeleton->translated_mask());
    }
    return {};
  };
  return run_into_library(job, *sink, command.output, *shard, provenance, "noise");
}

int run_join(const JoinCommand& command) {
  std::vector<fs::path> parts;
  for (const std::string& arg : command.parts) {
    std::error_code ec;
    if (fs::is_directory(arg, ec)) {
      for (const auto& entry : fs::directory_iterator(arg, ec))
        if (entry.path().extension() == ".h5") parts.push_back(entry.path());
    } else if (fs::is_regular_file(arg, ec)) {
      parts.push_back(arg);
    } else {
      return usage_error("join", arg + ": no such file or folder");
    }
  }
  std::sort(parts.begin(), parts.end());
  if (parts.empty()) return usage_error("join", "no part files (*.h5) found");
  std::string error;
  io::Provenance provenance;
  if (auto first = io::LibraryReader::open(parts.front(), &error)) {
    provenance = first->provenance().value_or(io::Provenance{});
  } else {
    return usage_error("join", error);
  }
  const fs::path tmp = command.output + ".tmp";
  if (!io::join_libraries(parts, tmp, provenance, &error)) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return usage_error("join", error);
  }
  std::error_code ec;
  fs::rename(tmp, command.output, ec);
  if (ec) return usage_error("join", "cannot rename " + tmp.string() + ": " + ec.message());
  fmt::print(stderr, "join: {} parts into {}\n", parts.size(), command.output);
  return 0;
}

int run_info(const InfoCommand& command) {
  std::string extension = fs::path(command.input).extension().string();
  for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (extension == ".bvh") return run_info_bvh(command);
  std::string error;
  auto source = LibrarySource::open(command.input, &error);
  if (!source) return usage_error("info", error);
  const io::LibraryReader& reader = source->reader();
  std::size_t frames = 0, joint_frames = 0;
  std::map<std::string, std::pair<int, int>> skeletons;  // name -> (joints, clips)
  nlohmann::json clips = nlohmann::json::array(), unreadable = nlohmann::json::array();
  for (const auto& h : reader.clips()) {
    if (!h.error.empty()) {
      unreadable.push_back({{"clip", h.path}, {"error", h.error}});
      continue;
    }
    frames += std::size_t(h.frames);
    joint_frames += std::size_t(h.frames) * std::size_t(h.joints);
    auto& s = skeletons[h.skeleton];
    s.first = h.joints;
    ++s.second;
    clips.push_back({{"path", h.path},
                     {"frames", h.frames},
                     {"joints", h.joints},
                     {"frame_time", h.frame_time},
                     {"skeleton", h.skeleton},
                     {"source", h.source}});
  }
  nlohmann::json j;
  j["file"] = command.input;
  j["clips"] = reader.clips().size() - unreadable.size();
  j["frames"] = frames;
  j["joint_frames"] = joint_frames;
  nlohmann::json sk = nlohmann::json::array();
  for (const auto& [name, s] : skeletons)
    sk.push_back({{"name", name}, {"joints", s.first}, {"clips", s.second}});
  j["skeletons"] = sk;
  if (const auto p = reader.provenance()) {
    j["provenance"] = {{"method", p->method},
                       {"parameters", nlohmann::json::parse(p->parameters_json, nullptr, false)},
                       {"engine_version", p->engine_version},
                       {"input_file", p->input_file},
                       {"created", p->created}};
  }
  if (command.joints) {
    // Garbage joints, read clip by clip (the data, not only the headers), classified and listed
    // as filter's pop stage does (nothing repaired).
    ConditioningTally tally;
    for (std::size_t i = 0; i < source->count(); ++i) {
      std::optional<Clip> clip = source->read(i, &error);
      if (!clip) continue;  // already listed as unreadable
      tally.add(source->clip_path(i), *clip,
                condition_rotations(PopsMode::off, clip->rotation_span(), clip->frame_time));
    }
    j["garbage_joints"] = {{"joints", tally.garbage_joints}, {"by_clip", tally.garbage}};
  }
  if (command.check) {
    // Every clip through the validation filter and export apply (skeleton, shapes, storage,
    // values), so info vouches for exactly what they accept.
    for (std::size_t i = 0; i < source->count(); ++i) {
      if (!reader.clips()[i].error.empty()) continue;  // already listed as unreadable
      std::optional<Clip> clip = source->read(i, &error);
      std::string problem = clip ? io::validate_clip(*clip) : error;
      if (clip && !problem.empty())
        problem = fmt::format("{}: clip '{}': {}", command.input, source->clip_path(i), problem);
      if (!problem.empty())
        unreadable.push_back({{"clip", source->clip_path(i)}, {"error", problem}});
    }
    j["checked"] = source->count();
  }
  j["unreadable"] = unreadable;
  if (command.list_clips) j["clip_list"] = clips;
  if (command.json) {
    fmt::print("{}\n", j.dump());
    return unreadable.empty() ? 0 : 1;
  }
  fmt::print("{}: {} clips, {} frames, {} joint-frames\n", command.input,
             j["clips"].get<std::size_t>(), frames, joint_frames);
  for (const auto& s : sk)
    fmt::print("  skeleton {}: {} joints, {} clips\n", s["name"].get<std::string>(),
               s["joints"].get<int>(), s["clips"].get<int>());
  if (j.contains("provenance")) {
    const auto& p = j["provenance"];
    fmt::print("  provenance: {} {} from {} ({}, {})\n", p["method"].get<std::string>(),
               p["parameters"].dump(), p["input_file"].get<std::string>(),
               p["engine_version"].get<std::string>(), p["created"].get<std::string>());
  }
  if (command.list_clips)
    for (const auto& c : clips)
      fmt::print("  {}  {} frames x {} joints  {:.6g} s/frame\n", c["path"].get<std::string>(),
                 c["frames"].get<int>(), c["joints"].get<int>(), c["frame_time"].get<double>());
  if (j.contains("garbage_joints")) {
    fmt::print("  garbage joints: {} in {} clips\n",
               j["garbage_joints"]["joints"].get<std::size_t>(),
               j["garbage_joints"]["by_clip"].size());
    for (const auto& c : j["garbage_joints"]["by_clip"]) {
      std::string names;
      for (const auto& g : c["joints"])
        names += fmt::format("{}{} ({})", names.empty() ? "" : ", ", g["joint"].get<std::string>(),
                             g["class"].get<std::string>());
      fmt::print("  {}: {}\n", c["clip"].get<std::string>(), names);
    }
  }
  for (const auto& u : unreadable)
    fmt::print(stderr, "mocap-clean: info: {}: {}\n", u["clip"].get<std::string>(),
               u["error"].get<std::string>());
  if (command.check)
    fmt::print("  check: {} of {} clips valid\n", source->count() - unreadable.size(),
               source->count());
  return unreadable.empty() ? 0 : 1;
}

}  // namespace mocap::engine
