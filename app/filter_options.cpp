#include "app/filter_options.hpp"

#include <fmt/core.h>

#include <limits>
#include <string>

#include "core/quaternion.hpp"

namespace mocap::engine {

void FilterOptions::add_to(CLI::App& cmd, const std::string& default_method) {
  method = default_method;
  cmd.add_option("--method,-m", method,
                 "bof: bilateral orientation filter (Courty 2008): smooths jitter, keeps edges\n"
                 "nlpm: non-local pose means (Dean & Lewis 2017): averages similar poses\n"
                 "gaussian | butterworth | moving-mean: linear filters (Lee-Shin construction)\n"
                 "kalman: constant-velocity RTS smoother (Lee-Shin), a baseline\n"
                 "auto: the method and its parameters chosen per clip from its measured noise\n"
                 "none: copy (checks the round trip)")
      ->transform(CLI::IsMember(
          {"none", "bof", "nlpm", "gaussian", "butterworth", "moving-mean", "kalman", "auto"},
          CLI::ignore_case))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--sigma-t", sigma_t,
                 "bof, gaussian: temporal width in frames (bof: 0 = automatic, from the noise)")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--window,-k", window,
                 "bof, gaussian: half-width k in frames (0 = ceil(3 sigma_t))")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--sigma-g", sigma_g,
                 "bof: range width, full rotation angle, in rad or e.g. 10deg (0 = automatic, from "
                 "the noise)")
      ->transform(kAngle)
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--iterations", iterations,
                 "bof: how many times the filter runs on its own output")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--kernel", kernel,
                 "bof: gaussian, or paper (Courty's printed kernel, for comparison)")
      ->check(CLI::IsMember({"gaussian", "paper"}))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--sigma-p", sigma_p,
                 "bof: range width for translations in the file's length unit (0 = none: Gaussian)")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--search-radius,-K", search_radius, "nlpm: search window K (2K+1 poses)")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--patch-radius,-P", patch_radius, "nlpm: patch radius P (2P+1 poses)")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--h", h,
                 "nlpm: strength in rad or e.g. 2deg (0 = automatic, from the estimated noise)")
      ->transform(kAngle)
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--space", space, "nlpm: tangent (default), or log (the paper, literally)")
      ->check(CLI::IsMember({"tangent", "log"}))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--nlpm-range", nlpm_range,
                 "nlpm: per-joint range term, off (the spec's nlpm), auto (5 x the estimated "
                 "noise) or a width in rad or e.g. 10deg: a joint that disagrees cannot drag the "
                 "others")
      ->transform(kAngle)
      ->check([](const std::string& v) -> std::string {
        if (v == "off" || v == "auto") return "";
        const std::optional<double> x = finite_number(v);
        return x && *x > 0 ? "" : "expected off, auto or a positive width in radians, got " + v;
      })
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--translation-sigma-t", translation_sigma_t,
                 "nlpm: Gaussian width in frames for the position channels (pose weights do not "
                 "follow a trajectory), auto (from the estimated position noise) or 0 (keep)")
      ->check([](const std::string& v) -> std::string {
        if (v == "auto") return "";
        const std::optional<double> x = finite_number(v);
        return x && *x >= 0 ? "" : "expected auto or a width in frames >= 0, got " + v;
      })
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--order", order, "butterworth: filter order n")
      ->check(CLI::Range(1, 8))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--cutoff", cutoff, "butterworth: single-pass -3 dB cut-off in Hz")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--passes", passes, "moving-mean: passes of Blender's Smooth Keys mask")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--kalman-lambda", kalman_lambda,
                 "kalman: process over measurement noise q/r (0 = automatic, from the noise)")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--boundary", boundary,
                 "samples beyond the clip's ends: mirror, hold, extrapolate")
      ->check(CLI::IsMember({"mirror", "hold", "extrapolate"}))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--pops", pops,
                 "before the filter: repair pops (samples that jump away and come back) by "
                 "slerp; detect: only count them; auto: repair at 60 fps and more, only count "
                 "below (a 30 fps limb moves too fast to tell); off: the spec's filter exactly "
                 "(garbage joints neither looked for nor kept). Default: auto with --method "
                 "auto; off with a named method, which then is the spec's filter exactly")
      ->check(CLI::IsMember({"auto", "repair", "detect", "off"}))
      ->group("Cleaning");
  cmd.add_option("--garbage-joints", garbage_joints,
                 "joints that are constant, move only by float rounding or flip by ~pi "
                 "(uncaptured): keep them as they came (and out of nlpm's pose distance), or "
                 "filter them like the others (ignored with --pops off)")
      ->check(CLI::IsMember({"keep", "filter"}))
      ->capture_default_str()
      ->group("Cleaning");
  cmd.add_option("--feet", feet,
                 "after the filter: lock each planted foot (contacts found on the input) in "
                 "place by two-bone IK on its leg, blended in and out over 0.1 s; off: leave the "
                 "filter's result. Default: lock with --method auto; off with a named method")
      ->check(CLI::IsMember({"lock", "off"}))
      ->group("Cleaning");
  cmd.add_option("--guard", guard,
                 "last: a clip whose joint positions come out with more jitter or more foot "
                 "skating than they went in with (the clip as read, over its own contacts) "
                 "falls back to the filter without the lock, then to the input (pops repaired) "
                 "locked, then to the input, so cleaning never makes a capture worse on what it "
                 "can measure. Default: on with --method auto; off with a named method")
      ->check(CLI::IsMember({"on", "off"}))
      ->group("Cleaning");
  auto* split_on = cmd.add_flag(
      "--split-impossible", split_impossible_on,
      "filter separately the segments between physically impossible steps (a joint turning "
      "faster than min(150 rad/s x frame time, 2 rad) in one step, e.g. CMU's synthetic T-pose "
      "frame 0), so no filter smears such a jump. Default: on with --method auto, off with a "
      "named method, which then is the spec's filter exactly");
  split_on->group("Cleaning");
  cmd.add_flag("--no-split-impossible", split_impossible_off,
               "filter each clip whole, across impossible steps")
      ->excludes(split_on)
      ->group("Cleaning");
  cmd.add_option("--translations", translations, "filter the position channels too, or keep them")
      ->check(CLI::IsMember({"filter", "keep"}))
      ->capture_default_str()
      ->group("Filter");
  cmd.add_option("--shard-joints", shard_joints, "joints per task (per-joint methods)")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Engine");
  cmd.add_option("--shard-frames", shard_frames, "frames per task (nlpm)")
      ->check(kPositive)
      ->capture_default_str()
      ->group("Engine");
}

FilterSettings FilterOptions::settings() const {
  FilterSettings s;
  s.method = parse_method(method).value_or(Method::none);
  const Boundary b = parse_boundary(boundary).value_or(Boundary::mirror);
  s.bilateral.sigma_t = sigma_t;
  s.bilateral.sigma_g = sigma_g;
  s.bilateral.window = window;
  s.bilateral.iterations = iterations;
  s.bilateral.kernel = kernel == "paper" ? BilateralKernel::paper : BilateralKernel::gaussian;
  s.bilateral.boundary = b;
  s.bilateral.sigma_p = sigma_p > 0 ? sigma_p : std::numeric_limits<double>::infinity();
  s.linear.sigma_t = sigma_t;
  s.linear.window = window;
  s.linear.order = order;
  s.linear.cutoff = cutoff;
  s.linear.passes = passes;
  s.linear.boundary = b;
  s.nlpm.search_radius = search_radius;
  s.nlpm.patch_radius = patch_radius;
  s.nlpm.h = h;
  s.nlpm.space = space == "log" ? NlpmSpace::log : NlpmSpace::tangent;
  s.nlpm.boundary = b;
  s.kalman.lambda = kalman_lambda;
  s.kalman.boundary = b;
  s.filter_translations = translations == "filter";
  // A named method is the spec's filter unless a pop stage is asked for; `auto` cleans fully.
  const PopsMode method_default =
      s.method == Method::automatic ? PopsMode::automatic : PopsMode::off;
  s.pops = pops.empty() ? method_default : parse_pops_mode(pops).value_or(method_default);
  s.keep_garbage_joints = garbage_joints == "keep";
  // On by default where the engine chooses anyway (auto): CMU's T-pose frame 0 stays a T-pose.
  s.split_impossible =
      split_impossible_on || (!split_impossible_off && s.method == Method::automatic);
  s.nlpm.translation_sigma_t =
      translation_sigma_t == "auto" ? kAutomaticTranslationSigma : std::stod(translation_sigma_t);
  s.lock_feet = feet.empty() ? s.method == Method::automatic : feet == "lock";
  s.guard_motion = guard.empty() ? s.method == Method::automatic : guard == "on";
  s.nlpm_range = nlpm_range == "off" ? 0.0 : nlpm_range == "auto" ? -1.0 : std::stod(nlpm_range);
  s.shard_joints = shard_joints;
  s.shard_frames = shard_frames;
  return s;
}

std::vector<std::string> FilterOptions::warnings() const {
  // Angles are full rotation angles in rad; a value past these is almost surely degrees given
  // without "deg" (a bof range of pi/2 already treats every step as jitter).
  constexpr double kRadiansPerDegree = kPi / 180.0;
  std::vector<std::string> out;
  auto check = [&](const char* name, double value, double limit, const char* why) {
    if (value > limit)
      out.push_back(
          fmt::format("{} {:g} rad ({:.4g} deg) is implausible: {}; for degrees write "
                      "{:g}deg",
                      name, value, value / kRadiansPerDegree, why, value));
  };
  check("--sigma-g", sigma_g, kPi / 2, "steps smaller than it are smoothed as jitter");
  check("--h", h, kPi / 2, "every pose counts as similar to every other");
  if (nlpm_range != "off" && nlpm_range != "auto")
    check("--nlpm-range", std::stod(nlpm_range), kPi, "no joint can disagree by more than pi");
  return out;
}

void add_run_options(CLI::App& cmd, RunOptions& run) {
  cmd.add_option("--threads,-j", run.threads,
                 "worker threads (0 = all cores); output is identical for any count")
      ->check(kNonNegative)
      ->capture_default_str()
      ->group("Engine");
  cmd.add_flag("--json", run.json, "print a machine-readable summary on stdout")->group("Engine");
  cmd.add_flag("!--no-progress", run.progress,
               "no progress bar (it is shown only on a terminal anyway)")
      ->group("Engine");
}

}  // namespace mocap::engine
