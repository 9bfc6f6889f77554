// `mocap-clean demo`: the main job on the built-in default library. Writes the procedural clips
// (ground truth), adds seeded noise, cleans the noisy files end to end through the same engine as
// `clean`, and scores the result against the ground truth.
#include <fmt/core.h>

#include <cmath>
#include <filesystem>

#include "app/commands.hpp"
#include "app/report.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/library/demo_library.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "kernels/metrics.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/position_metrics.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

namespace {

// Joint position error (MPJPE) of `result` against `truth` after forward kinematics, in mm (the
// built-in skeleton is in cm), over the frames eval scores; NaN when the shapes differ.
double position_error_mm(const Clip& result, const Clip& truth) {
  const std::vector<float> r = joint_positions(result), g = joint_positions(truth);
  if (r.empty() || r.size() != g.size()) return std::nan("");
  PositionSums sums;
  add_position_error({r.data(), result.frames, result.joints()},
                     {g.data(), truth.frames, truth.joints()},
                     scored_frames(0, truth.frames, truth.frame_time), sums);
  return 10 * sums.mpjpe();
}

}  // namespace

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
    fmt::print(
        "demo: cleaned with --method {} into {}\n(rotations: PSNR, higher is better; joint "
        "positions after forward kinematics: MPJPE, lower is better)\n\n{:<26} {:>7} {:>7} {:>13} "
        "{:>13} {:>8} {:>13} {:>13}\n",
        to_string(settings.method), clean_dir.string(), "clip", "frames", "joints", "noisy PSNR",
        "cleaned PSNR", "gain", "noisy MPJPE", "cleaned MPJPE");
  for (std::size_t i = 0; i < library.size(); ++i) {
    const DemoClip& demo = library[i];
    io::BvhReadResult cleaned = io::read_bvh(clean_dir / demo.relative_path);
    if (!cleaned.clip) continue;  // reported as a failure by clean_files
    const double before = psnr(noisy_clips[i].rotation_view(), demo.clip.rotation_view());
    const double after = psnr(cleaned.clip->rotation_view(), demo.clip.rotation_view());
    const double error_before = position_error_mm(noisy_clips[i], demo.clip);
    const double error_after = position_error_mm(*cleaned.clip, demo.clip);
    scores.push_back(
        {{"clip", demo.relative_path},
         {"noisy_psnr_db", before},
         {"cleaned_psnr_db", after},
         {"noisy_rmse_rad", rmse(noisy_clips[i].rotation_view(), demo.clip.rotation_view())},
         {"cleaned_rmse_rad", rmse(cleaned.clip->rotation_view(), demo.clip.rotation_view())},
         {"noisy_mpjpe_mm", error_before},
         {"cleaned_mpjpe_mm", error_after}});
    if (!command.run.json)
      fmt::print(
          "{:<26} {:>7} {:>7} {:>10.2f} dB {:>10.2f} dB {:>+5.2f} dB {:>10.2f} mm {:>10.2f} mm\n",
          demo.relative_path, demo.clip.frames, demo.clip.joints(), before, after, after - before,
          error_before, error_after);
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
