#pragma once
// Runs one eval method on one segment of a noisy clip: at a grid point, or with the engine's
// automatic parameters (what a user gets without giving any), through the same method table as
// the pipeline (engine/clip/methods.hpp: resolve_parameters, run_method):
//   bof          sigma_g and sigma_t from sigma_hat (automatic_bilateral, clip/filter_settings)
//   nlpm         h = kNlpmAutoFactor sigma_hat (clip/filter_settings), K = 10, P = 5
//   gaussian     sigma_t = 1 frame;  butterworth  order 2, 6 Hz;  moving-mean  5 passes
//   kalman       lambda = kalman_auto_lambda(sigma_hat, frame_time) (kernels/kalman.hpp)
// Translations (the position channels) take each method's translation path, as in the engine:
// nlpm's Gaussian width comes from the segment's estimated translation noise
// (automatic_translation_sigma_t) unless the grid gives translation_sigma_t.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>

#include "core/skeleton.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"
#include "engine/eval/eval_spec.hpp"

namespace mocap::engine::eval {

struct SegmentJob {
  RotationView noisy;   // the segment's frames, hemisphere-continuous
  RotationSpan output;  // same shape
  double frame_time = 1.0 / 120;
  double sigma_hat = 0;  // the segment's estimated noise (spec "Noise level estimate")
  // Optional, one entry per joint: joints copied as they came (garbage), and the joints nlpm's
  // pose distance looks at (empty: all).
  std::span<const std::uint8_t> kept_joints, distance_joints;
  // Optional, one entry per joint: of the kept joints, the flipping ones, then filtered between
  // their flips (clip/flip_pieces.hpp).
  std::span<const std::uint8_t> flip_joints;
  // Optional: the segment's translations in and out, and the joints with position channels.
  TranslationView translations;
  TranslationSpan output_translations;
  std::span<const std::uint8_t> translated_joints;
  double body_height = 0;  // file units: auto's test for noisy positions
  // Optional: the clip's skeleton, whose legs' hips and knees auto's per-joint cut-offs leave at
  // the clip's (leg_joints_of).
  const Skeleton* skeleton = nullptr;
};

// Filters `job` with `method` at `point`, or automatically when point is null. A segment of one
// frame, or one whose automatic parameters need a noise level and whose sigma_hat is 0 (nothing
// moves), is copied. `resolved` (optional) receives the parameters actually used.
Status filter_segment(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
                      nlohmann::json* resolved);

// The automatic rule of a method, as the report states it.
std::string automatic_rule(EvalMethod method);

}  // namespace mocap::engine::eval
