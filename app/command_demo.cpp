// `mocap-clean demo`: the main job on the built-in default library. Writes the procedural clips
// (ground truth), adds seeded noise, cleans the noisy files end to end through the same engine as
// `clean`, and scores the result against the ground truth.
#include <fmt/core.h>

#include <filesystem>

#include "app/commands.hpp"
#include "app/report.hpp"
#include "engine/library/demo_library.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "kernels/metrics.hpp"
#include "kernels/noise_model.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

int run_demo(const DemoCommand& command) {
  const fs::path root(command.output_dir);
  const fs::path truth_dir = root / "ground_truth", noisy_dir = root / "noisy",
                 clean_dir = root / "cleaned";
  const FilterSettings settings = command.filter.settings();
  if (const Status s = settings.validate(); !s.ok()) {
    fmt::print(stderr, "mocap-clean: demo: {}\n", s.message());
    return 2;
  }

  std::vector<DemoClip> library = make_demo_library();
  std::vector<SourceFile> noisy_files;
  std::vector<Clip> noisy_clips;
  for (std::size_t i = 0; i < library.size(); ++i) {
    const DemoClip& demo = library[i];
    Clip noisy = demo.clip;
    add_noise(GaussianNoise{command.noise_sigma, command.seed + i}, noisy.rotation_span());
    std::string error;
    for (const auto& [dir, clip] : {std::pair{truth_dir, &demo.clip},
                                    std::pair{noisy_dir, static_cast<const Clip*>(&noisy)}}) {
      const fs::path target = dir / demo.relative_path;
      std::error_code ec;
      fs::create_directories(target.parent_path(), ec);
      if (ec || !io::write_bvh(*clip, target, &error)) {
        fmt::print(stderr, "mocap-clean: demo: cannot write {}: {}\n", target.string(),
                   ec ? ec.message() : error);
        return 2;
      }
    }
    noisy_files.push_back({noisy_dir / demo.relative_path, demo.relative_path});
    noisy_clips.push_back(std::move(noisy));
  }
  if (!command.run.json)
    fmt::print(
        "demo: wrote {} procedural clips to {} and noisy copies (gaussian, sigma {} rad, seed {}) "
        "to {}\n",
        library.size(), truth_dir.string(), command.noise_sigma, command.seed, noisy_dir.string());

  RunSummary summary = clean_files(noisy_files, clean_dir.string(), settings, command.run);
  summary.command = "demo";

  nlohmann::json scores = nlohmann::json::array();
  if (!command.run.json)
    fmt::print("demo: cleaned with --method {} into {}\n\n{:<26} {:>7} {:>7} {:>13} {:>13} {:>8}\n",
               to_string(settings.method), clean_dir.string(), "clip", "frames", "joints",
               "noisy PSNR", "cleaned PSNR", "gain");
  for (std::size_t i = 0; i < library.size(); ++i) {
    const DemoClip& demo = library[i];
    io::BvhReadResult cleaned = io::read_bvh(clean_dir / demo.relative_path);
    if (!cleaned.clip) continue;  // reported as a failure by clean_files
    const double before = psnr(noisy_clips[i].rotation_view(), demo.clip.rotation_view());
    const double after = psnr(cleaned.clip->rotation_view(), demo.clip.rotation_view());
    scores.push_back(
        {{"clip", demo.relative_path},
         {"noisy_psnr_db", before},
         {"cleaned_psnr_db", after},
         {"noisy_rmse_rad", rmse(noisy_clips[i].rotation_view(), demo.clip.rotation_view())},
         {"cleaned_rmse_rad", rmse(cleaned.clip->rotation_view(), demo.clip.rotation_view())}});
    if (!command.run.json)
      fmt::print("{:<26} {:>7} {:>7} {:>10.2f} dB {:>10.2f} dB {:>+5.2f} dB\n", demo.relative_path,
                 demo.clip.frames, demo.clip.joints(), before, after, after - before);
  }
  if (!command.run.json) fmt::print("\n");
  summary.extra["scores"] = scores;
  summary.extra["noise_sigma"] = command.noise_sigma;
  report(summary, command.run.json);
  if (!command.run.json)
    fmt::print(
        stderr,
        "\nNext, on your own files:\n"
        "  mocap-clean clean MOCAP_FOLDER -o cleaned/    every .bvh below it, same layout\n"
        "  mocap-clean clean a.bvh -o a-clean.bvh        one file\n"
        "  mocap-clean info a.bvh                        joints, frame rate, garbage joints\n"
        "  mocap-clean eval MOCAP_FOLDER -o report/      which method suits your captures\n"
        "(mocap-clean is build/app/mocap-clean; `cmake --install build` puts it on the "
        "PATH.)\n");
  return summary.exit_status();
}

}  // namespace mocap::engine
