// The table of methods (engine/clip/methods.hpp): every method registered once under its name,
// its provenance and validation reached through its entry, and eval running the very job the
// pipeline runs (resolve_for_clip, plan_shards, run_shard) for equal parameters.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <set>
#include <string>

#include "engine/clip/filter_settings.hpp"
#include "engine/clip/methods.hpp"
#include "engine/clip/shard_work.hpp"
#include "engine/eval/eval_methods.hpp"
#include "engine/eval/eval_spec.hpp"
#include "engine/library/demo_library.hpp"
#include "kernels/noise_estimate.hpp"
#include "kernels/noise_model.hpp"

namespace mocap::engine {
namespace {

TEST(MethodTable, EveryMethodIsRegisteredOnceUnderItsName) {
  std::set<std::string_view> names;
  for (std::size_t i = 0; i < method_entries().size(); ++i) {
    const MethodEntry& e = method_entries()[i];
    EXPECT_EQ(std::size_t(e.method), i) << e.name << ": a method is its place in the table";
    EXPECT_TRUE(names.insert(e.name).second) << e.name << " registered twice";
    ASSERT_TRUE(parse_method(e.name)) << e.name;
    EXPECT_EQ(*parse_method(e.name), e.method);
    EXPECT_EQ(to_string(e.method), e.name);
    EXPECT_TRUE(e.validate && e.to_json && e.needs_noise && e.resolve && e.run) << e.name;
  }
  EXPECT_GE(names.size(), std::size_t(Method::automatic) + 1);  // the last named one
  EXPECT_FALSE(parse_method("bilateral"));
  // The methods the engine's rules name are the table's first entries, in the enum's order.
  const std::pair<Method, std::string_view> named[] = {{Method::none, "none"},
                                                       {Method::bof, "bof"},
                                                       {Method::nlpm, "nlpm"},
                                                       {Method::gaussian, "gaussian"},
                                                       {Method::butterworth, "butterworth"},
                                                       {Method::moving_mean, "moving-mean"},
                                                       {Method::kalman, "kalman"},
                                                       {Method::automatic, "auto"}};
  for (const auto& [method, name] : named) EXPECT_EQ(to_string(method), name);
}

TEST(MethodTable, SettingsKeepEachMethodsParametersByType) {
  FilterSettings s;
  // Unset: the kernel's defaults, or the engine's where they differ (nlpm's translations).
  EXPECT_EQ(s.param<BilateralParams>().sigma_g, BilateralParams{}.sigma_g);
  EXPECT_EQ(s.param<NlpmParams>().translation_sigma_t, kAutomaticTranslationSigma);
  EXPECT_NE(NlpmParams{}.translation_sigma_t, kAutomaticTranslationSigma);
  BilateralParams& b = s.edit<BilateralParams>();
  b.sigma_g = 0.3;
  s.edit<NlpmParams>().h = 0.07;  // another type added: `b` still refers to bof's
  s.edit<KalmanParams>().lambda = 2e-3;
  b.iterations = 2;
  EXPECT_EQ(s.param<BilateralParams>().sigma_g, 0.3);
  EXPECT_EQ(s.param<BilateralParams>().iterations, 2);
  EXPECT_EQ(s.param<NlpmParams>().h, 0.07);
  EXPECT_EQ(s.param<NlpmParams>().translation_sigma_t, kAutomaticTranslationSigma);
  EXPECT_EQ(s.param<KalmanParams>().lambda, 2e-3);
  // A copy owns its parameters.
  FilterSettings copy = s;
  copy.edit<BilateralParams>().sigma_g = 0.1;
  EXPECT_EQ(s.param<BilateralParams>().sigma_g, 0.3);
  EXPECT_EQ(copy.param<BilateralParams>().sigma_g, 0.1);
  EXPECT_EQ(copy.param<NlpmParams>().h, 0.07);
}

TEST(MethodTable, ProvenanceAndValidationGoThroughTheEntry) {
  for (const MethodEntry& e : method_entries()) {
    FilterSettings s;
    s.method = e.method;
    EXPECT_TRUE(s.validate().ok()) << e.name << ": " << s.validate().message();
    const nlohmann::json j = s.to_json();
    EXPECT_EQ(j.at("method"), std::string(e.name));
    nlohmann::json own;
    e.to_json(s, own);
    for (const auto& [key, value] : own.items())
      EXPECT_EQ(j.at(key), value) << e.name << " " << key;
  }
  FilterSettings bof;
  bof.method = Method::bof;
  bof.edit<BilateralParams>().sigma_g = 0;  // automatic: valid, recorded as such
  EXPECT_TRUE(bof.validate().ok());
  EXPECT_EQ(bof.to_json().at("sigma_g"), "auto");
  bof.edit<BilateralParams>().iterations = 0;
  EXPECT_FALSE(bof.validate().ok());
  FilterSettings butterworth;
  butterworth.method = Method::butterworth;
  butterworth.edit<LinearParams>().order = 9;  // the entry checks butterworth's own parameters
  EXPECT_FALSE(butterworth.validate().ok());
  butterworth.method = Method::gaussian;
  EXPECT_TRUE(butterworth.validate().ok());
}

// Each option of each method: a value other than its default, set through the entry's `apply`,
// comes back under the option's key in provenance (to_json); an option several methods declare
// is declared alike by all of them (one CLI option serves them all).
TEST(MethodTable, EveryOptionRoundTripsThroughProvenance) {
  int options = 0;
  for (const MethodEntry& e : method_entries())
    for (const MethodOption& o : e.options) {
      SCOPED_TRACE(std::string(e.name) + " " + std::string(o.flags));
      ASSERT_TRUE(o.apply);
      ASSERT_FALSE(o.json_key.empty());
      FilterSettings s;
      s.method = e.method;
      nlohmann::json expected;
      std::string word;
      double number = 0;
      if (o.type == MethodOption::Type::real) {
        number = o.default_number + 0.5;
        expected = number;
      } else if (o.type == MethodOption::Type::integer) {
        number = o.default_number + 1;
        expected = int(number);
      } else if (!o.choices.empty()) {
        EXPECT_NE(std::find(o.choices.begin(), o.choices.end(), o.default_word), o.choices.end());
        word = std::string(o.choices.back());
        ASSERT_NE(word, o.default_word);
        expected = word;
      } else {
        ASSERT_TRUE(o.check_word);
        EXPECT_EQ(o.check_word(std::string(o.default_word)), "");
        EXPECT_NE(o.check_word("-1"), "");
        word = "0.5";
        expected = 0.5;
      }
      o.apply(s, number, word);
      EXPECT_TRUE(s.validate().ok()) << s.validate().message();
      EXPECT_EQ(s.to_json().at(std::string(o.json_key)), expected);
      ++options;
      for (const MethodEntry& other : method_entries())
        for (const MethodOption& twin : other.options)
          if (twin.long_name() == o.long_name()) {
            EXPECT_EQ(twin.flags, o.flags) << other.name;
            EXPECT_EQ(twin.help, o.help) << other.name;
            EXPECT_EQ(int(twin.type), int(o.type)) << other.name;
            EXPECT_EQ(twin.default_number, o.default_number) << other.name;
            EXPECT_EQ(twin.default_word, o.default_word) << other.name;
          }
    }
  EXPECT_GE(options, 17);  // every method parameter of `clean --help`
}

TEST(MethodTable, EveryEvalMethodParsesAndNamesAnEngineMethod) {
  for (std::size_t i = 0; i < eval_variants().size(); ++i) {
    const EvalVariant& v = eval_variants()[i];
    const auto m = eval::parse_eval_method(v.name);
    ASSERT_TRUE(m) << v.name;
    EXPECT_EQ(m->index, int(i));
    EXPECT_EQ(eval::to_string(*m), v.name);
    EXPECT_FALSE(eval::automatic_rule(*m).empty());
    for (const GridAxis& axis : v.axes)  // a default axis is one a --grid may name
      EXPECT_NE(std::find(v.parameters.begin(), v.parameters.end(), axis.parameter),
                v.parameters.end())
          << v.name << "." << axis.parameter;
  }
}

// The demo's 120 fps walk with rotation noise `sigma` and position noise of `position`
// body heights.
Clip noisy_walk(double sigma, double position) {
  Clip clip = make_demo_library()[0].clip;
  add_noise(GaussianNoise{sigma, 3}, clip.rotation_span());
  const std::vector<std::uint8_t> translated = clip.skeleton->translated_mask();
  add_noise(PositionNoise{position * body_height(*clip.skeleton), 5}, clip.translation_span(),
            translated);
  return clip;
}

// The pipeline's result: resolve_for_clip, then every shard of plan_shards.
Clip pipeline(const FilterSettings& settings, const Clip& input, ResolvedSettings* resolved) {
  *resolved = resolve_for_clip(settings, input);
  Clip out = input;
  for (const Shard& shard : plan_shards(resolved->settings, input.frames, input.joints()))
    EXPECT_TRUE(run_shard(*resolved, input, out, shard).ok());
  return out;
}

// eval's result on the whole clip as one segment, with the noise the pipeline estimated.
Clip eval_run(eval::EvalMethod method, const ParamPoint* point, const Clip& input,
              nlohmann::json* used) {
  Clip out = input;
  std::fill(out.rotations.begin(), out.rotations.end(), 0.0f);
  std::fill(out.translations.begin(), out.translations.end(), 0.0f);
  const std::vector<std::uint8_t> translated = input.skeleton->translated_mask();
  eval::SegmentJob job;
  job.noisy = input.rotation_view();
  job.output = out.rotation_span();
  job.frame_time = input.frame_time;
  job.sigma_hat = estimate_noise(input.rotation_view()).sigma;
  job.translations = input.translation_view();
  job.output_translations = out.translation_span();
  job.translated_joints = translated;
  job.body_height = body_height(*input.skeleton);
  job.skeleton = input.skeleton.get();
  EXPECT_TRUE(eval::filter_segment(method, point, job, used).ok());
  return out;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Each eval method without a grid point runs what `clean --method NAME` runs with its automatic
// parameters, and at a grid point what the same parameters given on the command line run: the
// same resolved parameters, the same bits. Three clips reach auto's three branches (nlpm below
// kAutoCleanBelow, bof from automatic_smoothing, the low-pass of noisy positions).
TEST(MethodTable, EvalRunsThePipelinesJobForEqualParameters) {
  struct Case {
    const char* eval_method;
    ParamPoint point;  // empty: the automatic parameters
    FilterSettings settings;
  };
  auto with = [](Method method, auto&& change) {
    FilterSettings s;
    s.method = method;
    s.edit<BilateralParams>().sigma_g = s.edit<BilateralParams>().sigma_t =
        0;  // automatic, as eval's bof without a point
    change(s);
    return s;
  };
  auto keep = [](FilterSettings&) {};
  const std::vector<Case> cases = {
      {"bof", {}, with(Method::bof, keep)},
      {"bof",
       {{"sigma_g", 0.1}, {"sigma_t", 2}, {"iterations", 3}},
       with(Method::bof,
            [](FilterSettings& s) {
              s.edit<BilateralParams>().sigma_g = 0.1;
              s.edit<BilateralParams>().sigma_t = 2;
              s.edit<BilateralParams>().iterations = 3;
            })},
      {"nlpm", {}, with(Method::nlpm, keep)},
      {"nlpm",
       {{"h", 0.05}, {"K", 6}},
       with(Method::nlpm,
            [](FilterSettings& s) {
              s.edit<NlpmParams>().h = 0.05;
              s.edit<NlpmParams>().search_radius = 6;
            })},
      {"nlpm-robust",
       {},
       with(Method::nlpm, [](FilterSettings& s) { s.edit<NlpmParams>().range_sigma = -1; })},
      {"gaussian",
       {{"sigma_t", 2}},
       with(Method::gaussian, [](FilterSettings& s) { s.edit<LinearParams>().sigma_t = 2; })},
      {"butterworth", {}, with(Method::butterworth, keep)},
      {"moving-mean",
       {{"passes", 3}},
       with(Method::moving_mean, [](FilterSettings& s) { s.edit<LinearParams>().passes = 3; })},
      {"kalman", {}, with(Method::kalman, keep)},
      {"kalman",
       {{"lambda", 1e-3}},
       with(Method::kalman, [](FilterSettings& s) { s.edit<KalmanParams>().lambda = 1e-3; })},
      {"auto", {}, with(Method::automatic, keep)},
  };
  // Rotation noise (rad), position noise (body heights), and the method auto must choose.
  const struct {
    double sigma, position;
    Method chosen;
  } clips[] = {
      {0.001, 0, Method::nlpm}, {0.05, 0, Method::bof}, {0.02, 0.004, Method::butterworth}};
  int auto_smooth = 0, capped = 0, joint_cutoffs = 0;
  for (const auto& c : clips) {
    const Clip input = noisy_walk(c.sigma, c.position);
    for (const Case& k : cases) {
      SCOPED_TRACE(std::string(k.eval_method) + " at sigma " + std::to_string(c.sigma));
      ResolvedSettings resolved;
      const Clip expected = pipeline(k.settings, input, &resolved);
      ASSERT_FALSE(resolved.unchanged);
      nlohmann::json used;
      const auto method = eval::parse_eval_method(k.eval_method);
      ASSERT_TRUE(method);
      const Clip got = eval_run(*method, k.point.empty() ? nullptr : &k.point, input, &used);
      EXPECT_TRUE(same_bits(got.rotations, expected.rotations));
      EXPECT_TRUE(same_bits(got.translations, expected.translations));
      const FilterSettings& s = resolved.settings;
      if (k.settings.method == Method::automatic) {
        EXPECT_EQ(s.method, c.chosen);
        EXPECT_EQ(used.at("noisy_positions"), resolved.noisy_positions);
        auto_smooth += resolved.noisy_positions;
      }
      if (s.method == Method::bof) {
        EXPECT_EQ(used.at("sigma_g"), s.param<BilateralParams>().sigma_g);
        EXPECT_EQ(used.at("sigma_t"), s.param<BilateralParams>().sigma_t);
        EXPECT_EQ(used.at("iterations"), s.param<BilateralParams>().iterations);
      }
      if (s.method == Method::nlpm) {
        EXPECT_EQ(used.at("h"), s.param<NlpmParams>().h);
        EXPECT_EQ(used.at("translation_sigma_t"), s.param<NlpmParams>().translation_sigma_t);
        if (s.param<NlpmParams>().range_sigma != 0) {
          EXPECT_EQ(used.at("range_sigma"), s.param<NlpmParams>().range_sigma);
        }
        if (s.param<NlpmParams>().distance_cap != 0) {
          EXPECT_EQ(used.at("distance_cap"), s.param<NlpmParams>().distance_cap);
          ++capped;
        }
      }
      if (s.method == Method::kalman) {
        EXPECT_EQ(used.at("lambda"), s.param<KalmanParams>().lambda);
      }
      if (s.method == Method::butterworth) {
        const LinearParams& l = s.param<LinearParams>();
        EXPECT_EQ(used.at("order"), l.order);
        EXPECT_EQ(used.at("cutoff"), l.cutoff);
        if (k.settings.method == Method::automatic) {  // auto's per-joint cut-offs
          ASSERT_EQ(l.joint_cutoffs.size(), std::size_t(input.joints()));
          EXPECT_EQ(used.at("joint_cutoffs").get<std::vector<double>>(), l.joint_cutoffs);
          ++joint_cutoffs;
        }
      }
    }
  }
  EXPECT_EQ(auto_smooth, 1);    // the noisy positions branch was reached, and only there
  EXPECT_EQ(capped, 1);         // auto's nlpm alone caps the pose distance
  EXPECT_EQ(joint_cutoffs, 1);  // and its low-pass alone has per-joint cut-offs
}

}  // namespace
}  // namespace mocap::engine
