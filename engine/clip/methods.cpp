#include "engine/clip/methods.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "core/quaternion.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"

namespace mocap::engine {
namespace {

using nlohmann::json;

// A parameter that is automatic when 0 (or < 0) is recorded as "auto".
json or_auto(double value, bool automatic) {
  return automatic ? json("auto") : json(value);
}

double value(const ParamPoint* point, std::string_view name, double fallback) {
  if (point)
    for (const auto& [n, v] : *point)
      if (n == name) return v;
  return fallback;
}
bool has(const ParamPoint* point, std::string_view name) {
  return point &&
         std::any_of(point->begin(), point->end(), [&](const auto& p) { return p.first == name; });
}

// The options some methods share: one text, each method's own `apply`.
constexpr std::string_view kSigmaTHelp =
    "bof, gaussian: temporal width in frames (bof: 0 = automatic, from the noise)";
constexpr std::string_view kWindowHelp =
    "bof, gaussian: half-width k in frames (0 = ceil(3 sigma_t))";
MethodOption boundary_option(void (*apply)(FilterSettings&, double, const std::string&)) {
  return {.flags = "--boundary",
          .help = "samples beyond the clip's ends: mirror, hold, extrapolate",
          .type = MethodOption::Type::word,
          .default_word = "mirror",
          .choices = {"mirror", "hold", "extrapolate"},
          .after_methods = true,
          .json_key = "boundary",
          .apply = apply};
}

// The whole of `text` as a finite number, else nullopt (as the command line's number checks).
std::optional<double> finite_number(const std::string& text) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(x)) return std::nullopt;
  return x;
}

Status nothing_to_check(const FilterSettings&) {
  return {};
}
void no_parameters(const FilterSettings&, json&) {}
bool never(const FilterSettings&) {
  return false;
}
void nothing_to_resolve(FilterSettings&, const NoiseContext&) {}
Status runs_nothing(const FilterSettings&, const MotionIO&, std::span<const std::uint8_t>) {
  return {};
}

// bof (kernels/bilateral.hpp): sigma_g = 0 and sigma_t = 0 ask for automatic_bilateral.
bool bof_needs_noise(const FilterSettings& s) {
  return s.param<BilateralParams>().sigma_g == 0 || s.param<BilateralParams>().sigma_t == 0;
}

MethodEntry bof_entry() {
  return {
      .name = "bof",
      .help = "bof: bilateral orientation filter (Courty 2008): smooths jitter, keeps edges",
      .options = {{.flags = "--sigma-t",
                   .help = kSigmaTHelp,
                   .default_number = 1.0,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "sigma_t",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<BilateralParams>().sigma_t = x; }},
                  {.flags = "--window,-k",
                   .help = kWindowHelp,
                   .type = MethodOption::Type::integer,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "window",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<BilateralParams>().window = int(x); }},
                  {.flags = "--sigma-g",
                   .help = "bof: range width, full rotation angle, in rad or e.g. 10deg (0 = "
                           "automatic, from the noise)",
                   .default_number = 0.2,
                   .angle = true,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "sigma_g",
                   .implausible_above = kPi / 2,
                   .implausible_why = "steps smaller than it are smoothed as jitter",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<BilateralParams>().sigma_g = x; }},
                  {.flags = "--iterations",
                   .help = "bof: how many times the filter runs on its own output",
                   .type = MethodOption::Type::integer,
                   .default_number = 5,
                   .check = MethodOption::Check::positive,
                   .json_key = "iterations",
                   .apply =
                       [](FilterSettings& s, double x, const std::string&) {
                         s.edit<BilateralParams>().iterations = int(x);
                       }},
                  {.flags = "--kernel",
                   .help = "bof: gaussian, or paper (Courty's printed kernel, for comparison)",
                   .type = MethodOption::Type::word,
                   .default_word = "gaussian",
                   .choices = {"gaussian", "paper"},
                   .json_key = "kernel",
                   .apply =
                       [](FilterSettings& s, double, const std::string& w) {
                         s.edit<BilateralParams>().kernel =
                             w == "paper" ? BilateralKernel::paper : BilateralKernel::gaussian;
                       }},
                  {.flags = "--sigma-p",
                   .help = "bof: range width for translations in the file's length unit (0 = "
                           "none: Gaussian)",
                   .check = MethodOption::Check::non_negative,
                   .json_key = "sigma_p",
                   .apply =
                       [](FilterSettings& s, double x, const std::string&) {
                         s.edit<BilateralParams>().sigma_p =
                             x > 0 ? x : std::numeric_limits<double>::infinity();
                       }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<BilateralParams>().boundary =
                        parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .validate =
          [](const FilterSettings& s) {
            BilateralParams p = s.param<BilateralParams>();
            if (p.sigma_g == 0) p.sigma_g = 1;  // automatic: resolved per clip
            if (p.sigma_t == 0) p.sigma_t = 1;
            return p.validate();
          },
      .to_json =
          [](const FilterSettings& s, json& j) {
            const BilateralParams b = s.param<BilateralParams>();
            j["sigma_t"] = or_auto(b.sigma_t, b.sigma_t == 0);
            j["sigma_g"] = or_auto(b.sigma_g, b.sigma_g == 0);
            j["window"] = b.window;
            j["iterations"] = b.iterations;
            j["kernel"] = b.kernel == BilateralKernel::paper ? "paper" : "gaussian";
            j["boundary"] = std::string(to_string(b.boundary));
            if (std::isfinite(b.sigma_p)) j["sigma_p"] = b.sigma_p;
          },
      .needs_noise = bof_needs_noise,
      .resolve =
          [](FilterSettings& s, const NoiseContext& c) {
            if (bof_needs_noise(s))
              s.edit<BilateralParams>() =
                  automatic_bilateral(s.param<BilateralParams>(), c.sigma_hat, c.frame_time);
          },
      .run =
          [](const FilterSettings& s, const MotionIO& io, std::span<const std::uint8_t>) {
            return BilateralJob{s.param<BilateralParams>(), io}.run();
          },
  };
}

// nlpm (kernels/nlpm.hpp): h = 0 and a range < 0 ask for the noise; translation_sigma_t < 0 for
// automatic_translation_sigma_t.
bool nlpm_needs_noise(const FilterSettings& s) {
  const NlpmParams n = s.param<NlpmParams>();
  return n.h == 0 || n.range_sigma < 0;
}

MethodEntry nlpm_entry() {
  return {
      .name = "nlpm",
      .help = "nlpm: non-local pose means (Dean & Lewis 2017): averages similar poses",
      .options = {{.flags = "--search-radius,-K",
                   .help = "nlpm: search window K (2K+1 poses)",
                   .type = MethodOption::Type::integer,
                   .default_number = 10,
                   .check = MethodOption::Check::positive,
                   .json_key = "search_radius",
                   .apply =
                       [](FilterSettings& s, double x, const std::string&) {
                         s.edit<NlpmParams>().search_radius = int(x);
                       }},
                  {.flags = "--patch-radius,-P",
                   .help = "nlpm: patch radius P (2P+1 poses)",
                   .type = MethodOption::Type::integer,
                   .default_number = 5,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "patch_radius",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<NlpmParams>().patch_radius = int(x); }},
                  {.flags = "--h",
                   .help = "nlpm: strength in rad or e.g. 2deg (0 = automatic, from the estimated "
                           "noise)",
                   .angle = true,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "h",
                   .implausible_above = kPi / 2,
                   .implausible_why = "every pose counts as similar to every other",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<NlpmParams>().h = x; }},
                  {.flags = "--space",
                   .help = "nlpm: tangent (default), or log (the paper, literally)",
                   .type = MethodOption::Type::word,
                   .default_word = "tangent",
                   .choices = {"tangent", "log"},
                   .json_key = "space",
                   .apply =
                       [](FilterSettings& s, double, const std::string& w) {
                         s.edit<NlpmParams>().space =
                             w == "log" ? NlpmSpace::log : NlpmSpace::tangent;
                       }},
                  {.flags = "--nlpm-range",
                   .help = "nlpm: per-joint range term, off (the spec's nlpm), auto (5 x the "
                           "estimated noise) or a width in rad or e.g. 10deg: a joint that "
                           "disagrees cannot drag the others",
                   .type = MethodOption::Type::word,
                   .default_word = "off",
                   .angle = true,
                   .check_word = [](const std::string& v) -> std::string {
                     if (v == "off" || v == "auto") return "";
                     const std::optional<double> x = finite_number(v);
                     return x && *x > 0
                                ? ""
                                : "expected off, auto or a positive width in radians, got " + v;
                   },
                   .json_key = "range_sigma",
                   .implausible_above = kPi,
                   .implausible_why = "no joint can disagree by more than pi",
                   .apply =
                       [](FilterSettings& s, double, const std::string& w) {
                         s.edit<NlpmParams>().range_sigma = w == "off"    ? 0.0
                                                            : w == "auto" ? -1.0
                                                                          : std::stod(w);
                       }},
                  {.flags = "--translation-sigma-t",
                   .help = "nlpm: Gaussian width in frames for the position channels (pose "
                           "weights do not follow a trajectory), auto (from the estimated position "
                           "noise) or 0 (keep)",
                   .type = MethodOption::Type::word,
                   .default_word = "auto",
                   .check_word = [](const std::string& v) -> std::string {
                     if (v == "auto") return "";
                     const std::optional<double> x = finite_number(v);
                     return x && *x >= 0 ? "" : "expected auto or a width in frames >= 0, got " + v;
                   },
                   .json_key = "translation_sigma_t",
                   .apply =
                       [](FilterSettings& s, double, const std::string& w) {
                         s.edit<NlpmParams>().translation_sigma_t =
                             w == "auto" ? kAutomaticTranslationSigma : std::stod(w);
                       }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<NlpmParams>().boundary = parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .shard_by_frames = true,
      .validate =
          [](const FilterSettings& s) {
            NlpmParams p = s.param<NlpmParams>();
            if (!std::isfinite(p.range_sigma))
              return Status::error("nlpm's range sigma must be finite (0 = off, < 0 = automatic)");
            if (p.h == 0) p.h = 1;  // automatic: checked per clip
            if (p.range_sigma < 0) p.range_sigma = 0;
            if (p.translation_sigma_t < 0) p.translation_sigma_t = 0;
            return p.validate();
          },
      .to_json =
          [](const FilterSettings& s, json& j) {
            const NlpmParams n = s.param<NlpmParams>();
            j["search_radius"] = n.search_radius;
            j["patch_radius"] = n.patch_radius;
            j["h"] = or_auto(n.h, n.h == 0);
            j["space"] = n.space == NlpmSpace::log ? "log" : "tangent";
            j["range_sigma"] = or_auto(n.range_sigma, n.range_sigma < 0);
            j["distance_cap"] = n.distance_cap;
            j["translation_sigma_t"] = or_auto(n.translation_sigma_t, n.translation_sigma_t < 0);
            j["boundary"] = std::string(to_string(n.boundary));
          },
      .needs_noise = nlpm_needs_noise,
      .resolve =
          [](FilterSettings& s, const NoiseContext& c) {
            NlpmParams& n = s.edit<NlpmParams>();
            if (n.h == 0) n.h = kNlpmAutoFactor * c.sigma_hat;
            if (n.range_sigma < 0) n.range_sigma = kNlpmAutoRangeFactor * c.sigma_hat;
            if (c.automatic) {
              n.h = std::max(n.h, kAutoNlpmMinH);
              n.range_sigma = std::max(n.range_sigma, kAutoNlpmMinRange);
              n.distance_cap = kAutoNlpmDistanceCap * n.range_sigma;
            }
            n.range_sigma = std::max(0.0, n.range_sigma);
            if (n.translation_sigma_t < 0)
              n.translation_sigma_t =
                  automatic_translation_sigma_t(c.translation_noise(), c.frame_time, c.body_height);
          },
      .run =
          [](const FilterSettings& s, const MotionIO& io,
             std::span<const std::uint8_t> distance_joints) {
            return NlpmJob{s.param<NlpmParams>(), io, distance_joints}.run();
          },
  };
}

// The linear filters (kernels/linear_filter.hpp): one entry each, all on LinearParams.
template <LinearKind kKind>
void set_linear_kind(FilterSettings& s) {
  s.edit<LinearParams>().kind = kKind;
}
template <LinearKind kKind>
Status validate_linear(const FilterSettings& s) {
  LinearParams p = s.param<LinearParams>();
  p.kind = kKind;
  return p.validate();
}
Status run_linear(const FilterSettings& s, const MotionIO& io, std::span<const std::uint8_t>) {
  return LinearFilterJob{s.param<LinearParams>(), io}.run();
}

MethodEntry gaussian_entry() {
  return {
      .name = "gaussian",
      .help = "gaussian | butterworth | moving-mean: linear filters (Lee-Shin construction)",
      .options = {{.flags = "--sigma-t",
                   .help = kSigmaTHelp,
                   .default_number = 1.0,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "sigma_t",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<LinearParams>().sigma_t = x; }},
                  {.flags = "--window,-k",
                   .help = kWindowHelp,
                   .type = MethodOption::Type::integer,
                   .check = MethodOption::Check::non_negative,
                   .json_key = "window",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<LinearParams>().window = int(x); }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<LinearParams>().boundary = parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .normalize = set_linear_kind<LinearKind::gaussian>,
      .validate = validate_linear<LinearKind::gaussian>,
      .to_json =
          [](const FilterSettings& s, json& j) {
            j["sigma_t"] = s.param<LinearParams>().sigma_t;
            j["window"] = s.param<LinearParams>().window;
            j["boundary"] = std::string(to_string(s.param<LinearParams>().boundary));
          },
      .needs_noise = never,
      .resolve = nothing_to_resolve,
      .run = run_linear,
  };
}

MethodEntry butterworth_entry() {
  return {
      .name = "butterworth",
      .help = {},  // on gaussian's line
      .options = {{.flags = "--order",
                   .help = "butterworth: filter order n",
                   .type = MethodOption::Type::integer,
                   .default_number = 2,
                   .check = MethodOption::Check::range,
                   .min = 1,
                   .max = 8,
                   .json_key = "order",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<LinearParams>().order = int(x); }},
                  {.flags = "--cutoff",
                   .help = "butterworth: single-pass -3 dB cut-off in Hz",
                   .default_number = 6.0,
                   .check = MethodOption::Check::positive,
                   .json_key = "cutoff",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<LinearParams>().cutoff = x; }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<LinearParams>().boundary = parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .normalize = set_linear_kind<LinearKind::butterworth>,
      .validate = validate_linear<LinearKind::butterworth>,
      .to_json =
          [](const FilterSettings& s, json& j) {
            j["order"] = s.param<LinearParams>().order;
            j["cutoff"] = s.param<LinearParams>().cutoff;
            if (!s.param<LinearParams>().joint_cutoffs.empty())
              j["joint_cutoffs"] = s.param<LinearParams>().joint_cutoffs;
            j["boundary"] = std::string(to_string(s.param<LinearParams>().boundary));
          },
      .needs_noise = never,
      .resolve = nothing_to_resolve,
      .run = run_linear,
  };
}

MethodEntry moving_mean_entry() {
  return {
      .name = "moving-mean",
      .help = {},  // on gaussian's line
      .options = {{.flags = "--passes",
                   .help = "moving-mean: passes of Blender's Smooth Keys mask",
                   .type = MethodOption::Type::integer,
                   .default_number = 5,
                   .check = MethodOption::Check::positive,
                   .json_key = "passes",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<LinearParams>().passes = int(x); }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<LinearParams>().boundary = parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .normalize = set_linear_kind<LinearKind::moving_mean>,
      .validate = validate_linear<LinearKind::moving_mean>,
      .to_json =
          [](const FilterSettings& s, json& j) {
            j["passes"] = s.param<LinearParams>().passes;
            j["boundary"] = std::string(to_string(s.param<LinearParams>().boundary));
          },
      .needs_noise = never,
      .resolve = nothing_to_resolve,
      .run = run_linear,
  };
}

// kalman (kernels/kalman.hpp): lambda = 0 asks for kalman_auto_lambda.
MethodEntry kalman_entry() {
  return {
      .name = "kalman",
      .help = "kalman: constant-velocity RTS smoother (Lee-Shin), a baseline",
      .options = {{.flags = "--kalman-lambda",
                   .help = "kalman: process over measurement noise q/r (0 = automatic, from the "
                           "noise)",
                   .check = MethodOption::Check::non_negative,
                   .json_key = "lambda",
                   .apply = [](FilterSettings& s, double x,
                               const std::string&) { s.edit<KalmanParams>().lambda = x; }},
                  boundary_option([](FilterSettings& s, double, const std::string& w) {
                    s.edit<KalmanParams>().boundary = parse_boundary(w).value_or(Boundary::mirror);
                  })},
      .validate = [](const FilterSettings& s) { return s.param<KalmanParams>().validate(); },
      .to_json =
          [](const FilterSettings& s, json& j) {
            const double lambda = s.param<KalmanParams>().lambda;
            j["lambda"] = or_auto(lambda, lambda == 0);
            j["boundary"] = std::string(to_string(s.param<KalmanParams>().boundary));
          },
      .needs_noise = [](const FilterSettings& s) { return s.param<KalmanParams>().lambda == 0; },
      .resolve =
          [](FilterSettings& s, const NoiseContext& c) {
            if (s.param<KalmanParams>().lambda == 0)
              s.edit<KalmanParams>().lambda = kalman_auto_lambda(c.sigma_hat, c.frame_time);
          },
      .run =
          [](const FilterSettings& s, const MotionIO& io, std::span<const std::uint8_t>) {
            return KalmanJob{s.param<KalmanParams>(), io}.run();
          },
  };
}

MethodEntry none_entry() {
  return {
      .name = "none",
      .help = "none: copy (checks the round trip)",
      .validate = nothing_to_check,
      .to_json = no_parameters,
      .needs_noise = never,
      .resolve = nothing_to_resolve,
      .run = runs_nothing,
  };
}

// auto: replaced per clip by the method choose_automatic picks (resolve_parameters).
MethodEntry automatic_entry() {
  return {
      .name = "auto",
      .help =
          "auto: the method and its parameters chosen per clip from its measured noise; then "
          "the joints the clip turns about one axis (knees, elbows) put back on it",
      .validate = nothing_to_check,
      .to_json = no_parameters,
      .needs_noise = [](const FilterSettings&) { return true; },
      .resolve = nothing_to_resolve,
      .run = runs_nothing,
  };
}

// A method's place here is its Method: the named ones first, in the enum's order; a new method
// goes at the end. Built on first use, so that no static initializer depends on another file's.
std::vector<MethodEntry> numbered(std::vector<MethodEntry> table) {
  for (std::size_t i = 0; i < table.size(); ++i) table[i].method = Method(i);
  return table;
}
const std::vector<MethodEntry>& entries() {
  static const std::vector<MethodEntry> table =
      numbered({none_entry(), bof_entry(), nlpm_entry(), gaussian_entry(), butterworth_entry(),
                moving_mean_entry(), kalman_entry(), automatic_entry()});
  return table;
}

// eval's variants --------------------------------------------------------------------------

FilterSettings asked(Method method) {
  FilterSettings s;
  s.method = method;
  return s;
}

std::optional<FilterSettings> bof_point(const ParamPoint* point, double sigma_hat,
                                        double frame_time) {
  FilterSettings s = asked(Method::bof);
  BilateralParams& p = s.edit<BilateralParams>();
  if (!point) {
    p.sigma_g = p.sigma_t = 0;  // both automatic
    return s;
  }
  p.sigma_t = value(point, "sigma_t", p.sigma_t);
  p.sigma_g = value(point, "sigma_g", p.sigma_g);
  p.iterations = int(value(point, "iterations", p.iterations));
  // The factors follow the noise as automatic_bilateral's rule does (its calibration grid).
  if (has(point, "sigma_t_factor")) {
    if (!(sigma_hat > 0)) return std::nullopt;
    p.sigma_t = std::max(1.0, value(point, "sigma_t_factor", 0.0) * std::sqrt(sigma_hat) *
                                  std::pow(1.0 / (120.0 * frame_time), 0.75));
  }
  if (has(point, "sigma_g_factor")) {
    if (!(sigma_hat > 0)) return std::nullopt;
    p.sigma_g = std::max(value(point, "sigma_g_floor", 0.0),
                         value(point, "sigma_g_factor", 1.0) * sigma_hat);
  }
  return s;
}

// nlpm, and with `robust` its range term relative to the noise (nlpm-robust).
template <bool kRobust>
std::optional<FilterSettings> nlpm_point(const ParamPoint* point, double sigma_hat, double) {
  FilterSettings s = asked(Method::nlpm);
  NlpmParams& p = s.edit<NlpmParams>();
  p.search_radius = int(value(point, "K", p.search_radius));
  p.patch_radius = int(value(point, "P", p.patch_radius));
  if (kRobust && !(sigma_hat > 0)) return std::nullopt;
  if (has(point, "h")) {
    p.h = value(point, "h", 0);
  } else if (has(point, "h_factor")) {
    if (!(sigma_hat > 0)) return std::nullopt;
    p.h = value(point, "h_factor", kNlpmAutoFactor) * sigma_hat;
  }  // else 0: kNlpmAutoFactor sigma_hat
  if (kRobust && has(point, "range_factor"))
    p.range_sigma = value(point, "range_factor", kNlpmAutoRangeFactor) * sigma_hat;
  else if (kRobust)
    p.range_sigma = -1;  // kNlpmAutoRangeFactor sigma_hat
  if (has(point, "translation_sigma_t"))
    p.translation_sigma_t = value(point, "translation_sigma_t", 0);
  return s;
}

template <bool kRobust>
json nlpm_used(const FilterSettings& s) {
  const NlpmParams n = s.param<NlpmParams>();
  json used = {{"h", n.h},
               {"K", n.search_radius},
               {"P", n.patch_radius},
               {"translation_sigma_t", n.translation_sigma_t}};
  if (kRobust) used["range_sigma"] = n.range_sigma;
  if (n.distance_cap > 0) used["distance_cap"] = n.distance_cap;  // auto's
  return used;
}

std::optional<FilterSettings> linear_point(Method method, const ParamPoint* point) {
  FilterSettings s = asked(method);
  LinearParams& p = s.edit<LinearParams>();
  p.sigma_t = value(point, "sigma_t", p.sigma_t);
  p.cutoff = value(point, "cutoff", p.cutoff);
  p.order = int(value(point, "order", p.order));
  p.passes = int(value(point, "passes", p.passes));
  return s;
}

std::optional<FilterSettings> kalman_point(const ParamPoint* point, double sigma_hat,
                                           double frame_time) {
  FilterSettings s = asked(Method::kalman);
  if (has(point, "lambda")) {
    s.edit<KalmanParams>().lambda = value(point, "lambda", 0);
  } else if (has(point, "lambda_scale")) {
    if (!(sigma_hat > 0)) return std::nullopt;
    s.edit<KalmanParams>().lambda =
        kalman_auto_lambda(sigma_hat, frame_time, value(point, "lambda_scale", 0));
  }  // else 0: kalman_auto_lambda
  return s;
}

template <Method kMethod>
bool chose(const FilterSettings& s) {
  return s.method == kMethod;
}

// Modest grids around each method's default, wide enough to bracket the best value from 0.008 to
// 0.12 rad of gaussian noise on CMU-like clips (4 to 8 points each; eval's time budget).
const std::vector<EvalVariant>& variants() {
  static const std::vector<EvalVariant> table = {
      {.name = "bof",
       .method = Method::bof,
       .parameters = {"sigma_g", "sigma_g_factor", "sigma_g_floor", "sigma_t", "sigma_t_factor",
                      "iterations"},
       .axes = {{"sigma_g", {0.05, 0.1, 0.2, 0.4}}, {"sigma_t", {1, 2}}},
       .rule =
           [] {
             return fmt::format(
                 "sigma_g={:g}*sigma_hat sigma_t=max(1, {:g}*sqrt(sigma_hat)) iterations=5 "
                 "(--sigma-g 0 --sigma-t 0)",
                 kBofAutoSigmaGFactor, kBofAutoSigmaTFactor);
           },
       .settings = bof_point,
       .used =
           [](const FilterSettings& s) {
             const BilateralParams b = s.param<BilateralParams>();
             return json{
                 {"sigma_g", b.sigma_g}, {"sigma_t", b.sigma_t}, {"iterations", b.iterations}};
           },
       .reports = chose<Method::bof>},
      {.name = "nlpm",
       .method = Method::nlpm,
       .parameters = {"h", "h_factor", "K", "P", "translation_sigma_t"},
       .axes = {{"h", {0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32}}},
       .rule = [] { return fmt::format("h={:g}*sigma_hat K=10 P=5", kNlpmAutoFactor); },
       .settings = nlpm_point<false>,
       .used = nlpm_used<false>,
       .reports =
           [](const FilterSettings& s) {
             return s.method == Method::nlpm && s.param<NlpmParams>().range_sigma == 0;
           }},
      {.name = "gaussian",
       .method = Method::gaussian,
       .parameters = {"sigma_t"},
       .axes = {{"sigma_t", {0.5, 1, 1.5, 2, 3, 4}}},
       .rule = [] { return std::string("sigma_t=1 (spec default)"); },
       .settings = [](const ParamPoint* point, double,
                      double) { return linear_point(Method::gaussian, point); },
       .used =
           [](const FilterSettings& s) {
             return json{{"sigma_t", s.param<LinearParams>().sigma_t}};
           },
       .reports = chose<Method::gaussian>},
      {.name = "butterworth",
       .method = Method::butterworth,
       .parameters = {"cutoff", "order"},
       .axes = {{"cutoff", {2, 4, 6, 10, 15, 25}}},
       .rule = [] { return std::string("order=2 cutoff=6 Hz (spec defaults)"); },
       .settings = [](const ParamPoint* point, double,
                      double) { return linear_point(Method::butterworth, point); },
       .used =
           [](const FilterSettings& s) {
             const LinearParams l = s.param<LinearParams>();
             json used{{"cutoff", l.cutoff}, {"order", l.order}};
             if (!l.joint_cutoffs.empty()) used["joint_cutoffs"] = l.joint_cutoffs;  // auto's
             return used;
           },
       .reports = chose<Method::butterworth>},
      {.name = "moving-mean",
       .method = Method::moving_mean,
       .parameters = {"passes"},
       .axes = {{"passes", {1, 2, 5, 10, 20}}},
       .rule = [] { return std::string("passes=5 (spec default)"); },
       .settings = [](const ParamPoint* point, double,
                      double) { return linear_point(Method::moving_mean, point); },
       .used =
           [](const FilterSettings& s) {
             return json{{"passes", s.param<LinearParams>().passes}};
           },
       .reports = chose<Method::moving_mean>},
      {.name = "kalman",
       .method = Method::kalman,
       .parameters = {"lambda", "lambda_scale"},
       .axes = {{"lambda", {1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1}}},
       .rule =
           [] {
             return fmt::format("lambda={:g}*(120*frame_time)^2.5/sigma_hat^3", kKalmanAutoScale);
           },
       .settings = kalman_point,
       .used =
           [](const FilterSettings& s) {
             return json{{"lambda", s.param<KalmanParams>().lambda}};
           },
       .reports = chose<Method::kalman>},
      // Relative to the noise: h = 1.2 sigma_hat, as nlpm's rule.
      {.name = "nlpm-robust",
       .note = "nlpm with the per-joint range term",
       .method = Method::nlpm,
       .parameters = {"h", "h_factor", "range_factor", "K", "P", "translation_sigma_t"},
       .axes = {{"range_factor", {1.5, 2, 3, 5, 8}}},
       .rule =
           [] {
             return fmt::format("h={:g}*sigma_hat range_sigma={:g}*sigma_hat K=10 P=5",
                                kNlpmAutoFactor, kNlpmAutoRangeFactor);
           },
       .settings = nlpm_point<true>,
       .used = nlpm_used<true>,
       .reports =
           [](const FilterSettings& s) {
             return s.method == Method::nlpm && s.param<NlpmParams>().range_sigma != 0;
           }},
      // No grid: the automatic choice only; its runs are reported as the variant it chose.
      {.name = "auto",
       .note = "--method auto",
       .method = Method::automatic,
       .parameters = {},
       .axes = {},
       .rule =
           [] {
             return std::string(
                 "--method auto: the method and parameters chosen per clip (choose_automatic), "
                 "after pop repair, then its hinges put back on their curves (hinge_stage)");
           },
       .settings = [](const ParamPoint*, double,
                      double) { return std::optional(asked(Method::automatic)); },
       .used = nullptr,
       .reports = never},
  };
  return table;
}

}  // namespace

std::span<const MethodEntry> method_entries() {
  return entries();
}

const MethodEntry& method_entry(Method method) {
  return entries()[std::size_t(method)];
}

const MethodEntry* find_method(std::string_view name) {
  for (const MethodEntry& e : entries())
    if (e.name == name) return &e;
  return nullptr;
}

std::span<const EvalVariant> eval_variants() {
  return variants();
}

std::string_view MethodOption::long_name() const {
  std::string_view name = flags.substr(0, flags.find(','));
  while (!name.empty() && name.front() == '-') name.remove_prefix(1);
  return name;
}

FilterSettings resolve_parameters(const FilterSettings& settings, const NoiseContext& context,
                                  bool noisy_positions) {
  FilterSettings s = settings;
  NoiseContext c = context;
  if (s.method == Method::automatic) {
    s = choose_automatic(settings, context.sigma_hat, noisy_positions, context.frame_time);
    c.automatic = true;
    if (s.method == Method::butterworth && context.joint_motion) {
      const std::vector<double> power = context.joint_motion(joint_cutoff_lag(context.frame_time));
      std::vector<std::uint8_t> legs;
      if (const Skeleton* sk = context.skeleton)
        legs =
            leg_joints_of(find_feet(sk->joint_names, sk->parents, sk->offsets), int(power.size()));
      LinearParams& l = s.edit<LinearParams>();
      l.joint_cutoffs =
          automatic_joint_cutoffs(l.cutoff, context.sigma_hat, power, legs, context.frame_time);
    }
  }
  const MethodEntry& entry = method_entry(s.method);
  if (entry.normalize) entry.normalize(s);
  entry.resolve(s, c);
  return s;
}

Status run_method(const FilterSettings& settings, MotionIO io,
                  std::span<const std::uint8_t> distance_joints) {
  // --translations keep: no joint counts as translated.
  std::vector<std::uint8_t> none;
  if (!settings.filter_translations) {
    none.assign(io.translated_joints.size(), 0);
    io.translated_joints = none;
  }
  return method_entry(settings.method).run(settings, io, distance_joints);
}

}  // namespace mocap::engine
