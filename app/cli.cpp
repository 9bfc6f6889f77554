#include "app/cli.hpp"

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "app/cli_checks.hpp"
#include "app/cluster.hpp"
#include "app/commands.hpp"
#include "app/eval_command.hpp"
#include "core/version.hpp"

namespace mocap::engine {
namespace {

constexpr const char* kFooter = R"(Examples:
  mocap-clean demo                                   clean the built-in library, print scores
  mocap-clean clean mocap/ -o cleaned/               every .bvh below mocap/, same layout out:
                                                     pops repaired, method chosen per clip
  mocap-clean clean a.bvh -o a-clean.bvh             one file
  mocap-clean import mocap/ -o lib.h5                a whole library into one HDF5 file
  mocap-clean filter lib.h5 -o clean.h5              the library through the default cleaning
  mocap-clean export clean.h5 -o cleaned/            back to BVH, same folder layout
  mocap-clean info clean.h5                          clips, frames, skeletons, provenance
  mocap-clean eval mocap/ -o report/                 noise, filter, score: tables and plots

Run `mocap-clean <command> --help` for the options and examples of each command.
Angles are in radians; append "deg" for degrees (--sigma-g 10deg).

Exit status: 0 all clips written; 1 some (or all) clips failed (named on stderr), the rest
written; 2 usage error, or the run could not start (missing source, no .bvh file, ...).
README.md describes each method, its parameters and the library file's layout; the pages of
docs/ explain each stage in depth (automatic parameters, positions, pops, feet, eval, performance).)";

// Ends each command's help: its own examples.
std::string examples(std::initializer_list<const char*> lines, const char* note = nullptr) {
  std::string out = "Examples:\n";
  for (const char* line : lines) out += std::string("  ") + line + "\n";
  if (note)
    out += std::string("\n") + note;
  else
    out.pop_back();
  return out;
}

}  // namespace

int run_cli(int argc, char** argv) {
  CLI::App app{
      "mocap-clean " + std::string(kVersion) +
          ": removes sensor jitter and pops from whole motion-capture libraries\n"
          "without blurring the motion (bilateral orientation filter, non-local pose means,\n"
          "and classic linear filters for comparison).",
      "mocap-clean"};
  app.footer(kFooter);
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(kVersion));
  app.get_formatter()->column_width(34);

  CleanCommand clean;
  CLI::App* clean_cmd =
      app.add_subcommand("clean", "filter BVH files or folders into a folder (same layout)");
  clean_cmd->add_option("SRC", clean.sources, "BVH files or folders (searched recursively)")
      ->required();
  clean_cmd
      ->add_option("-o,--output", clean.output_dir,
                   "output folder, or a file name ending in .bvh when there is one source file")
      ->required();
  auto* resume_flag = clean_cmd->add_flag(
      "--resume", clean.resume,
      "finish an interrupted run: keep the outputs written with the same parameters and newer "
      "than their input (recorded in OUT/.mocap-clean.jsonl), clean the rest");
  clean_cmd
      ->add_flag("--overwrite", clean.overwrite,
                 "write into an output folder that already holds files, replacing them")
      ->excludes(resume_flag);
  clean_cmd->add_option("--report", clean.report_dir,
                        "write a review page into this folder (open DIR/index.html): every clip, "
                        "what cleaning did, the skeleton before and after in 3-D");
  clean.filter.add_to(*clean_cmd, "auto");
  add_run_options(*clean_cmd, clean.run);
  clean_cmd->footer(examples(
      {"mocap-clean clean mocap/ -o cleaned/              pops repaired, method chosen per clip",
       "mocap-clean clean a.bvh -o a-clean.bvh            one file",
       "mocap-clean clean mocap/ -o cleaned/ --resume     finish an interrupted run",
       "mocap-clean clean mocap/ -o out/ --method bof --sigma-g 10deg   the spec's bof exactly",
       "mocap-clean clean a.bvh b.bvh -o out/ --method nlpm --json"},
      "Each file keeps its path relative to the folder it was found in. A file that fails\n"
      "is named with its error; the others are still written (exit status 1). An output\n"
      "folder that already holds files is refused without --resume or --overwrite.\n"
      "In depth, in the source tree: docs/automatic-parameters.md (--method auto),\n"
      "docs/pops.md (--pops, --garbage-joints), docs/feet.md (--feet), docs/positions.md\n"
      "(--guard: \"Never worse\")."));

  DemoCommand demo;
  CLI::App* demo_cmd = app.add_subcommand(
      "demo", "the main job on the built-in library: procedural clips, known noise, clean, score");
  demo_cmd->add_option("-o,--output", demo.output_dir, "where the demo writes its folders")
      ->capture_default_str();
  demo_cmd->add_option("--noise", demo.noise_sigma, "gaussian noise level in rad")
      ->check(kNonNegative)
      ->capture_default_str();
  demo_cmd->add_option("--seed", demo.seed, "noise seed")->capture_default_str();
  demo.filter.add_to(*demo_cmd, "auto");
  add_run_options(*demo_cmd, demo.run);
  demo_cmd->footer(
      examples({"mocap-clean demo                         the default cleaning",
                "mocap-clean demo --method bof --noise 0.05   another method, more noise",
                "mocap-clean demo -o /tmp/demo --json         scores as JSON"}));

  ImportCommand import;
  CLI::App* import_cmd =
      app.add_subcommand("import", "BVH files or folders into one library file (HDF5)");
  import_cmd->add_option("SRC", import.sources, "BVH files or folders (searched recursively)")
      ->required();
  import.output.add_to(*import_cmd);
  add_run_options(*import_cmd, import.run);
  import_cmd->footer(
      examples({"mocap-clean import mocap/ -o lib.h5",
                "mocap-clean import a.bvh b.bvh -o lib.h5 --compression deflate"},
               "Clips keep their folder layout: mocap/02/02_01.bvh becomes /clips/02/02_01."));

  FilterCommand filter;
  CLI::App* filter_cmd =
      app.add_subcommand("filter", "filter every clip of a library into a new library");
  filter_cmd->add_option("LIB", filter.input, "the library file to read")
      ->required()
      ->check(CLI::ExistingFile);
  filter.output.add_to(*filter_cmd);
  filter_cmd->add_option("--report", filter.report_dir,
                         "write a review page into this folder (open DIR/index.html): every clip, "
                         "what cleaning did, the skeleton before and after in 3-D");
  filter.filter.add_to(*filter_cmd, "auto");
  add_run_options(*filter_cmd, filter.run);
  filter_cmd->footer(
      examples({"mocap-clean filter lib.h5 -o clean.h5                  the default cleaning",
                "mocap-clean filter lib.h5 -o bof.h5 --method bof --threads 8",
                "mocap-clean filter lib.h5 -o clean.h5 --resume         finish an interrupted run"},
               "The output has the input's layout (runs chain) and records the method and its\n"
               "parameters in /provenance, and per clip what was done (attributes method,\n"
               "parameters, noise_sigma and a dataset pops in each clip's group).\n"
               "An interrupted run leaves OUT valid with the clips finished so far; --resume\n"
               "completes it. In depth, in the source tree: docs/automatic-parameters.md,\n"
               "docs/pops.md, docs/feet.md, docs/positions.md (the guard), docs/reliability.md."));

  ExportCommand export_;
  CLI::App* export_cmd =
      app.add_subcommand("export", "a library's clips back to BVH files (same layout)");
  export_cmd->add_option("LIB", export_.input, "the library file to read")
      ->required()
      ->check(CLI::ExistingFile);
  export_cmd->add_option("-o,--output", export_.output_dir, "output folder")->required();
  add_run_options(*export_cmd, export_.run);
  export_cmd->footer(examples({"mocap-clean export clean.h5 -o cleaned/"},
                              "/clips/02/02_01 becomes cleaned/02/02_01.bvh."));

  NoiseCommand noise;
  CLI::App* noise_cmd =
      app.add_subcommand("noise", "add the spec's seeded noise models to a library");
  noise_cmd->add_option("LIB", noise.input, "the library file to read")
      ->required()
      ->check(CLI::ExistingFile);
  noise.output.add_to(*noise_cmd);
  noise_cmd
      ->add_option("--model", noise.model, "gaussian: jitter on every sample; impulse: sparse pops")
      ->check(CLI::IsMember({"gaussian", "impulse"}))
      ->capture_default_str();
  noise_cmd
      ->add_option("--sigma", noise.sigma,
                   "gaussian: per-axis standard deviation in rad (or e.g. 2deg)")
      ->transform(kAngle)
      ->check(kNonNegative)
      ->capture_default_str();
  noise_cmd->add_option("--rate", noise.rate, "impulse: probability per joint-sample")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  noise_cmd
      ->add_option("--min-angle", noise.min_angle, "impulse: smallest pop in rad (or e.g. 2deg)")
      ->transform(kAngle)
      ->check(kNonNegative)
      ->capture_default_str();
  noise_cmd
      ->add_option("--max-angle", noise.max_angle, "impulse: largest pop in rad (or e.g. 2deg)")
      ->transform(kAngle)
      ->check(kNonNegative)
      ->capture_default_str();
  noise_cmd
      ->add_option("--position-sigma", noise.position_sigma,
                   "also jitter every position channel: per-axis standard deviation as a fraction "
                   "of each clip's body height (0.004: 7 mm on a 1.7 m body, a plausible solver "
                   "error; eval's +pos:F)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  noise_cmd->add_option("--seed", noise.seed, "the same seed and build give the same noise")
      ->capture_default_str();
  add_run_options(*noise_cmd, noise.run);
  noise_cmd->footer(
      examples({"mocap-clean noise lib.h5 -o noisy.h5 --sigma 0.03 --seed 7",
                "mocap-clean noise lib.h5 -o solve.h5 --sigma 0.02 --position-sigma 0.004",
                "mocap-clean noise lib.h5 -o pops.h5 --model impulse --rate 0.01"}));

  JoinCommand join;
  CLI::App* join_cmd =
      app.add_subcommand("join", "join part files (of shards or ranks) into one library file");
  join_cmd->add_option("PARTS", join.parts, "part files, or folders of them (OUT.h5.parts)")
      ->required();
  join_cmd->add_option("-o,--output", join.output, "the library file to write")->required();
  join_cmd->footer(examples({"mocap-clean join clean.h5.parts -o clean.h5"}));

  InfoCommand info;
  CLI::App* info_cmd = app.add_subcommand(
      "info", "what a library or BVH file holds: clips, frames, skeletons, provenance");
  info_cmd->add_option("FILE", info.input, "the library file (.h5) or BVH file to read")
      ->required()
      ->check(CLI::ExistingFile);
  info_cmd->add_flag("--clips", info.list_clips, "list every clip");
  info_cmd->add_flag("--joints", info.joints,
                     "read every clip and name its garbage joints: constant, moving only by "
                     "float rounding, or flipping by ~pi (uncaptured)");
  info_cmd->add_flag("--check", info.check,
                     "read and validate every clip as filter and export do; exit 1 naming each "
                     "clip that fails");
  info_cmd->add_flag("--json", info.json, "machine-readable output on stdout");
  info_cmd->footer(
      examples({"mocap-clean info clean.h5 --clips", "mocap-clean info lib.h5 --joints --json",
                "mocap-clean info walk.bvh               joints, channel orders, garbage joints"}));

  EvalCommand eval;
  CLI::App* eval_cmd = add_eval_subcommand(app, eval);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // CLI11's own messages get the program's prefix like every other error.
    fmt::print(stderr,
               "mocap-clean: {}\nRun `mocap-clean --help` or `mocap-clean COMMAND --help`.\n",
               e.what());
    return 2;
  }
  // Only import, filter and noise split a library across MPI ranks; every other command would run
  // whole on each rank and write the same outputs at once: rank 0 runs it, the others stop.
  if (cluster().active() && !*import_cmd && !*filter_cmd && !*noise_cmd) {
    if (cluster().rank != 0) return 0;
    fmt::print(stderr,
               "mocap-clean: this command runs on rank 0 only ({} ranks idle): only import, "
               "filter and noise split across ranks; eval uses the threads of its node\n",
               cluster().size - 1);
  }
  for (const auto& [cmd, options] :
       {std::pair{clean_cmd, &clean.filter}, std::pair{demo_cmd, &demo.filter},
        std::pair{filter_cmd, &filter.filter}})
    if (*cmd)
      for (const std::string& w : options->warnings())
        fmt::print(stderr, "mocap-clean: {}: warning: {}\n", cmd->get_name(), w);
  if (*clean_cmd) return run_clean(clean);
  if (*demo_cmd) return run_demo(demo);
  if (*import_cmd) return run_import(import);
  if (*filter_cmd) return run_filter(filter);
  if (*export_cmd) return run_export(export_);
  if (*noise_cmd) {
    if (noise.min_angle > noise.max_angle) {
      fmt::print(stderr, "mocap-clean: noise: --min-angle must not exceed --max-angle\n");
      return 2;
    }
    return run_noise(noise);
  }
  if (*info_cmd) return run_info(info);
  if (*eval_cmd) return run_eval(eval);
  if (*join_cmd) return run_join(join);
  return 2;
}

}  // namespace mocap::engine
