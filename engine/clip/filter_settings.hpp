#pragma once
// What a filter run is asked to do: the method, every parameter of the spec, and how a clip is
// cut into shards. Resolves the automatic parameters per clip and runs one shard's job.
#include <any>
#include <cstdint>
#include <deque>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/clip.hpp"
#include "core/status.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine {

// A method is its place in the table of methods (engine/clip/methods.cpp). These are the ones
// the engine's own rules name; a method added to the table needs no name here (find_method).
// automatic: chosen per clip from what the clip shows (choose_automatic below).
enum class Method : std::uint8_t {
  none,
  bof,
  nlpm,
  gaussian,
  butterworth,
  moving_mean,
  kalman,
  automatic
};

// Pop repair before the filter (engine/clip/clip_conditioning.hpp): off = the spec's filter
// exactly; auto = repair at kPopsRepairMinFps and above; from kAutoRepairMinFps to there, repair a
// clip whose pop test flags at least kManyPopsFlagged of its samples (a clip with pops), and
// only count elsewhere.
enum class PopsMode { off, detect, repair, automatic };
// Below 60 fps a quadratic no longer follows fast limbs, and the low-rate test (skeleton and
// detour tests, clip_conditioning.hpp) still flags some fast motion and the captures' own
// glitches on a clean capture; repairing those costs more on light noise than pops gain, so auto
// repairs there only where the flags are many: a clip with pops flags several times the share a
// clip without them does, down to kAutoRepairMinFps; below it, clean motion alone flags that many
// (docs/pops.md, "Many pops": the shares measured at 10-30 fps). At 60 fps and
// above the same share adds the detour test to the pop test (clip_conditioning.hpp).
inline constexpr double kManyPopsFlagged = 0.004;
inline constexpr double kAutoRepairMinFps = 20;
inline constexpr double kPopsRepairMinFps = 60;
std::optional<PopsMode> parse_pops_mode(std::string_view name);
std::string_view to_string(PopsMode mode);

std::optional<Method> parse_method(std::string_view name);
std::string_view to_string(Method method);

// nlpm's automatic strength: h = kNlpmAutoFactor * sigma_hat (spec "Noise level estimate"),
// calibrated on ../shared/data/bvh with added noise (docs/automatic-parameters.md; `mocap-clean
// eval --grid nlpm.h_factor=...`): 1.2 is within 0.02 dB of the best h at 0.008, 0.03, 0.12 rad.
inline constexpr double kNlpmAutoFactor = 1.2;

// bof's automatic parameters, asked for with sigma_g = 0 and/or sigma_t = 0 (calibrated the same
// way, `--grid bof.sigma_g_factor=... --grid bof.sigma_t_factor=...`):
//   sigma_g = kBofAutoSigmaGFactor sigma_hat
//   sigma_t = max(1, kBofAutoSigmaTFactor sqrt(sigma_hat) (1 / (120 frame_time))^(3/4)) frames
// The temporal width must grow with the noise too: at sigma_t = 1 no sigma_g comes within 3.5 dB
// of the best at 0.12 rad. sqrt(sigma_hat) is the Wiener smoother's width for a motion spectrum
// falling as w^-4; the frame-rate factor follows from the same argument (the shared clips are all
// 120 fps, so it is not measured).
inline constexpr double kBofAutoSigmaGFactor = 3.0;
inline constexpr double kBofAutoSigmaTFactor = 10.0;
// `params` with its zero sigma_g / sigma_t replaced by the rule above.
BilateralParams automatic_bilateral(BilateralParams params, double sigma_hat, double frame_time);

// auto's bof (choose_automatic, rotation noise only): the number of passes grows with the noise,
// and the widths shrink as sqrt(passes) so the smoothing of all passes together (n Gaussian
// passes of width s act like one of width s sqrt(n)) follows the Wiener width sqrt(sigma_hat):
//   iterations n = clamp(round(sigma_hat / kAutoNoisePerIteration), 1, 5)
//   sigma_g = kAutoSigmaGFactor sigma_hat / sqrt(n)
//   sigma_t = max(1, kAutoSigmaTFactor sqrt(sigma_hat) (1 / (120 frame_time))^(1/2) / sqrt(n))
// Calibrated with `eval --grid bof.iterations=1,2,3,5 --grid bof.sigma_g_factor=2,3,4,5,6,8
// --grid bof.sigma_t_factor=7,10,15,20,28,40` on ../shared/data/bvh at 120 and 30 fps
// (docs/automatic-parameters.md): the best points had sigma_t sqrt(n) / sqrt(sigma_hat) of 20-28
// frames at 120 fps and 1.4x that (in units of automatic_bilateral's (fps / 120)^(3/4)) at 30 fps,
// i.e. a frame-rate exponent of 1/2, not 3/4; sigma_g 4-5 sigma_hat at one pass, 2-3 at 3-5 passes.
// sigma_g 4 (not 5) at one pass: at 30 fps and 0.008 rad 5 left one clip 0.32 dB below its
// noisy input, 4 none.
inline constexpr double kAutoNoisePerIteration = 0.06;
inline constexpr double kAutoSigmaGFactor = 4.0;
inline constexpr double kAutoSigmaTFactor = 25.0;
int automatic_iterations(double sigma_hat);
BilateralParams automatic_smoothing(double sigma_hat, double frame_time);

// nlpm's translation Gaussian (NlpmParams::translation_sigma_t, kernels/nlpm.hpp), asked for with
// --translation-sigma-t auto (the default). Translations without measurable noise (below
// kNoisyPositions of the body's height, has_noisy_positions) are kept as they are: at 30 fps a
// root's own curvature is large, and a Gaussian of even one frame raised the joint position error
// of the shared clips by 10 % where their positions were clean (5.51 to 6.05 mm with 0.008 rad of
// rotation noise); 0 also where the clip is too short to measure a. For a locally quadratic
// trajectory of acceleration a
// (per frame^2) under i.i.d. noise sigma, a Gaussian of width s has squared bias a^2 s^4 / 4 and
// variance sigma^2 / (2 sqrt(pi) s); their sum is least at s* = (sigma^2 / (2 sqrt(pi) a^2))^(1/5).
// At s* the noise left still carries 0.87 a of second difference, about the motion's own: the
// rule widens s* by kTranslationSigmaFactor so a noisy root comes out with little more than its
// true jitter (the error grows by a few per cent). sigma and a come from
// estimate_translation_noise (kernels/noise_estimate.hpp). Capped at kTranslationSigmaMaxSeconds.
inline constexpr double kAutomaticTranslationSigma = -1;  // in FilterSettings: "auto"
inline constexpr double kTranslationSigmaFactor = 1.3;
inline constexpr double kTranslationSigmaMaxSeconds = 0.2;
double automatic_translation_sigma_t(TranslationNoise noise, double frame_time, double body_height);

// The skeleton's height in its rest pose, End Sites included (file units).
double body_height(const Skeleton& skeleton);

// nlpm's automatic range term (NlpmParams::range_sigma), asked for with --nlpm-range auto:
// range_sigma = kNlpmAutoRangeFactor * sigma_hat (docs/automatic-parameters.md).
inline constexpr double kNlpmAutoRangeFactor = 5.0;

struct FilterSettings {
  Method method = Method::none;
  // Before the filter (not for `none`, which copies): pop repair, and garbage joints (constant,
  // rounding-only, flipping) kept as they came and out of nlpm's pose distance. pops off turns
  // both off: the spec's filter exactly, on every joint.
  PopsMode pops = PopsMode::off;
  // --garbage-joints keep|filter (with pops detect|repair); keep: flipping joints between flips.
  bool keep_garbage_joints = true;
  // After the filter (not for `none`): pin the planted feet, contacts found on the input
  // (engine/clip/foot_stage.hpp). --feet lock|off; lock by default with --method auto only.
  bool lock_feet = false;
  // After the feet: a clip whose joint positions came out with more jitter or foot skating than
  // it was read with keeps the input instead (engine/clip/motion_guard.hpp). --guard on|off; on
  // by default with --method auto only.
  bool guard_motion = false;
  // Filter each segment between physically impossible steps (kernels/motion_split.hpp: CMU's
  // synthetic T-pose frame 0) as a clip of its own.
  bool split_impossible = false;
  bool filter_translations = true;  // --translations filter|keep
  int shard_joints = 8;             // joint block of per-joint methods
  int shard_frames = 256;           // time block of nlpm

  Status validate() const;
  nlohmann::json to_json() const;  // parameters as recorded in provenance

  // Each method's parameters, as its kernel's Params struct (BilateralParams, NlpmParams, ...),
  // kept by type: the table of methods reads and sets them, so a method's parameters need no
  // member here. param<P>() is default_params<P>() until edit<P>() sets it. Automatic markers
  // (bof's sigma_g, sigma_t == 0; nlpm's h == 0, range_sigma < 0, translation_sigma_t < 0;
  // kalman's lambda == 0) are resolved per clip by the table's `resolve`.
  template <class P>
  P param() const;
  template <class P>
  P& edit();

 private:
  // A deque: a reference edit() returned stays valid when another type is added.
  std::deque<std::any> params_;
};

// The parameters a method starts from: its kernel's defaults, except where the engine's differ.
template <class P>
P default_params() {
  return P{};
}
// nlpm's translations: automatic (the spec's translation rule for nlpm is withdrawn).
template <>
inline NlpmParams default_params<NlpmParams>() {
  return {.translation_sigma_t = kAutomaticTranslationSigma};
}

template <class P>
P FilterSettings::param() const {
  for (const std::any& a : params_)
    if (const P* p = std::any_cast<P>(&a)) return *p;
  return default_params<P>();
}

template <class P>
P& FilterSettings::edit() {
  for (std::any& a : params_)
    if (P* p = std::any_cast<P>(&a)) return *p;
  return *std::any_cast<P>(&params_.emplace_back(default_params<P>()));
}

// The per-clip resolution of automatic parameters, done once on the whole clip before sharding.
struct ResolvedSettings {
  FilterSettings settings;             // method automatic: the method it chose
  double noise_sigma = -1;             // estimated, when it was needed; -1 otherwise
  TranslationNoise translation_noise;  // estimated for auto and nlpm's automatic translation width
  bool noisy_positions = false;        // auto: has_noisy_positions
  bool unchanged = false;  // nothing to filter (1 frame, or no joint moves for automatic h)
  // Joints whose samples are copied as they came (garbage joints), one entry per joint; and the
  // joints nlpm's pose distance looks at (empty: all).
  std::vector<std::uint8_t> kept_joints, distance_joints;
  // Of the kept joints, the flipping ones, then filtered between their flips with flip_settings
  // (one entry per joint, or empty: none; clip/flip_pieces.hpp: flip_piece_settings).
  std::vector<std::uint8_t> flip_joints;
  FilterSettings flip_settings;
  // With split_impossible: the clip's segments between impossible steps (empty: none found).
  std::vector<Segment> segments;
};
// The joints nlpm's pose distance looks at when `garbage` (one entry per joint, nonzero =
// garbage) are left out: empty (all joints, the spec's distance) when none or all are garbage.
std::vector<std::uint8_t> distance_joints_without(std::span<const std::uint8_t> garbage);

// What the clip's conditioning measured on these very rotations, for resolve_for_clip to take
// instead of measuring again: the same functions on the same samples, so the same bits. Only
// given when the conditioning changed no sample (ClipConditioning::facts).
struct ClipFacts {
  std::span<const JointQuality> joints;            // classify_joints (empty: not known)
  const std::vector<Segment>* segments = nullptr;  // motion_segments, flipping joints skipped
};

// `garbage` (empty, or one entry per joint, nonzero = garbage) comes from the clip's
// conditioning: garbage joints stay out of the noise estimate and nlpm's distance and, with
// keep_garbage_joints, are copied as they came, the flipping ones then filtered between their
// flips (flip_joints).
ResolvedSettings resolve_for_clip(const FilterSettings& settings, const Clip& clip,
                                  std::span<const std::uint8_t> garbage = {},
                                  const ClipFacts& known = {});

// What --method auto picks for a clip of estimated noise sigma_hat (rad): the method and its
// parameters (docs/automatic-parameters.md):
//   sigma_hat < kAutoCleanBelow   nlpm, h = max(kNlpmAutoFactor sigma_hat, kAutoNlpmMinH),
//   (kAutoNlpmMinFps and above):  range = max(kNlpmAutoRangeFactor sigma_hat, kAutoNlpmMinRange)
//   otherwise:                    bof, automatic_smoothing (iterations and widths from sigma_hat
//                                 and the frame rate)
//   noisy positions:              butterworth of kAutoButterworthOrder, cut-off automatic_cutoff
//                                 (from sigma_hat and the frame rate), translations too, raised
//                                 per joint by automatic_joint_cutoffs
// Measured with `eval` on ../shared/data/bvh (9 CMU clips, gaussian 0.008-0.24 rad, 120 fps and
// --frame-step 4; grid over bof's iterations 1/2/3/5, sigma_g 2-8 sigma_hat, sigma_t factor
// 7-40): the best bof has ONE iteration at 0.008 and 0.03 rad, 2-3 at 0.12, 3-5 at 0.24, and
// beat nlpm with its range term at every level at 30 fps (by up to 0.5 dB) and matched it at
// 120 fps. Below kAutoCleanBelow (a capture with no noise to speak of: the clean CMU clips measure
// 0.0011-0.0023 rad at 120 fps) the floored nlpm stays: bof at one iteration left 1.7-1.96x the
// clean capture's joint-position jitter there against nlpm's 1.26x, whatever its sigma_g floor.
// Below kAutoNlpmMinFps the estimate cannot tell a capture with no noise: the clean CMU clips
// measure 0.0032-0.0097 rad at 30 fps (the motion between samples reads as noise), so the branch
// split them at random; bof kept them closer to the capture than nlpm did in rotations and joint
// positions, at a little more jitter and, without the lock, more skating on pops
// (docs/automatic-parameters.md, "Below 60 fps").
inline constexpr double kAutoCleanBelow = 0.004;
inline constexpr double kAutoNlpmMinFps = 60;
// Noisy positions: the position channels' noise (estimate_translation_noise) above
// kNoisyPositions of the body's height. Such a capture is a noisy solve, and what its viewer sees
// is joint positions, their error and their jitter, so auto chooses there on positions: the
// rotation-PSNR-best choices staircase and leave jitter, and a Gaussian-like smoother must blur a
// fast clip's motion before it brings the noise's jitter down. A Butterworth low-pass (zero-phase,
// order kAutoButterworthOrder, rotations and translations alike) keeps the motion's band and cuts
// the noise above it; its cut-off, automatic_cutoff,
//   kAutoCutoffHz (kAutoCutoffSigma / sigma_hat)^(1/6) (fps / 30)^(1/6)
// within [kAutoCutoffMinHz, kAutoCutoffMaxNyquist x Nyquist], falls as the noise rises and rises
// with the frame rate as the worst clip's joint position error asked in the calibration
// (docs/positions.md: eval's grid, the measurements, what it costs the rotations). On rotation-only
// noise the PSNR-best branches stay.
inline constexpr int kAutoButterworthOrder = 4;
inline constexpr double kAutoCutoffHz = 4.0;
inline constexpr double kAutoCutoffSigma = 0.02;
inline constexpr double kAutoCutoffMinHz = 1.0;
inline constexpr double kAutoCutoffMaxNyquist = 0.8;
double automatic_cutoff(double sigma_hat, double frame_time);
// Per joint, the cut-off rises with how fast the joint moves beyond its noise: one cut-off for
// the whole body blurred the fast joints (toes, feet, hands) of a fast clip below their noisy
// input's rotation error, while the joints that decide the joint positions (root, spine, hips)
// move slowly and keep it. With P_j the joint's lag-L acceleration power (kernels/joint_motion.hpp,
// L = round(fps / 30) frames so that it sees the same band at every rate) and
// snr_j = (P_j - 6 sigma_hat^2) / (6 sigma_hat^2):
//   f_j = f clamp((max(snr_j, 0) / kAutoJointCutoffSnr)^(1/3), 1, kAutoJointCutoffMaxFactor),
// within automatic_cutoff's bounds; the position channels keep f, and so do the legs' hips and
// knees (`legs`, leg_joints_of): they carry a planted foot, and raising theirs let 02_03's feet
// skate where its short contacts went unfound. Only ever raised: the slow proximal joints' motion
// hides under the noise (snr near 0) but is real, and a lower cut-off there moved every joint
// below them (docs/positions.md, "Per-joint cut-offs").
inline constexpr double kAutoJointCutoffSnr = 0.3;
inline constexpr double kAutoJointCutoffMaxFactor = 3.0;
int joint_cutoff_lag(double frame_time);  // L >= 1
// One entry per power (empty without sigma_hat); `legs` empty or one entry per joint.
std::vector<double> automatic_joint_cutoffs(double cutoff, double sigma_hat,
                                            std::span<const double> power,
                                            std::span<const std::uint8_t> legs, double frame_time);
// 1 on each leg's hip and knee joint (kernels/foot_contacts.hpp, FootChain), 0 elsewhere.
std::vector<std::uint8_t> leg_joints_of(std::span<const FootChain> feet, int joints);
inline constexpr double kNoisyPositions = 0.0015;
// Floors of auto's nlpm strength and range width. On a capture with no noise added (CMU clips:
// sigma_hat 0.001-0.002 rad) h = 1.2 sigma_hat and a range of 5 sigma_hat are so selective that
// which neighbours get weight changes from frame to frame: the output staircases, and the joint
// positions came out with 1.04-1.79x the input's jitter and 1.3-2.3x its foot skating (clean, the
// 9 shared clips, 120 fps). With these floors: jitter 0.24-1.04x, skating 0.47-1.21x
// (docs/positions.md).
inline constexpr double kAutoNlpmMinH = 0.015;
inline constexpr double kAutoNlpmMinRange = 0.1;
// auto's nlpm caps each joint's term of the pose distance at kAutoNlpmDistanceCap times its range
// width (NlpmParams::distance_cap): a capture's own one-frame glitch, or a pop the pop stage
// missed, otherwise makes every patch that holds it unlike its neighbours, and the weights then
// average a fast knee toward one side. Calibrated with eval on the shared clips, clean and with
// pops, at 120 and 30 fps (docs/automatic-parameters.md, "The distance cap").
inline constexpr double kAutoNlpmDistanceCap = 2.0;
FilterSettings choose_automatic(const FilterSettings& settings, double sigma_hat,
                                bool noisy_positions = false, double frame_time = 1.0 / 120);
// Whether a clip's position channels carry noise by the rule above (false without any).
bool has_noisy_positions(const TranslationNoise& noise, double body_height);

}  // namespace mocap::engine
