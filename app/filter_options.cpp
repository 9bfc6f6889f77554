#include "app/filter_options.hpp"

#include <fmt/core.h>

#include <limits>
#include <string>

#include "core/quaternion.hpp"
#include "engine/clip/methods.hpp"

namespace mocap::engine {

namespace {

// Every method option once (engine/clip/methods.hpp: the first declaration of a shared one), in
// the order --help lists them: the methods' own, then those of every method (--boundary).
std::vector<const MethodOption*> distinct_options() {
  std::vector<const MethodOption*> own, shared;
  auto listed = [&](const MethodOption& o) {
    for (const auto* list : {&own, &shared})
      for (const MethodOption* p : *list)
        if (p->long_name() == o.long_name()) return true;
    return false;
  };
  for (const MethodEntry& e : method_entries())
    for (const MethodOption& o : e.options)
      if (!listed(o)) (o.after_methods ? shared : own).push_back(&o);
  own.insert(own.end(), shared.begin(), shared.end());
  return own;
}

}  // namespace

FilterOptions::FilterOptions() {
  for (const MethodOption* o : distinct_options()) {
    const std::string name(o->long_name());
    if (o->type == MethodOption::Type::real) numbers[name] = o->default_number;
    if (o->type == MethodOption::Type::integer) integers[name] = int(o->default_number);
    if (o->type == MethodOption::Type::word) words[name] = std::string(o->default_word);
  }
}

double FilterOptions::number(std::string_view name) const {
  return numbers.find(name)->second;
}
int FilterOptions::integer(std::string_view name) const {
  return integers.find(name)->second;
}
const std::string& FilterOptions::word(std::string_view name) const {
  return words.find(name)->second;
}

void FilterOptions::add_to(CLI::App& cmd, const std::string& default_method) {
  method = default_method;
  // --method: the table's names, and one help line per method (none, which copies, last).
  std::vector<std::string> names;
  std::string help, none_help;
  for (const MethodEntry& e : method_entries()) {
    names.emplace_back(e.name);
    if (e.method == Method::none)
      none_help = e.help;
    else if (!e.help.empty())
      help += std::string(e.help) + "\n";
  }
  cmd.add_option("--method,-m", method, help + none_help)
      ->transform(CLI::IsMember(names, CLI::ignore_case))
      ->capture_default_str()
      ->group("Filter");
  for (const MethodOption* o : distinct_options()) {
    const std::string name(o->long_name());
    CLI::Option* option =
        o->type == MethodOption::Type::real
            ? cmd.add_option(std::string(o->flags), numbers[name], std::string(o->help))
        : o->type == MethodOption::Type::integer
            ? cmd.add_option(std::string(o->flags), integers[name], std::string(o->help))
            : cmd.add_option(std::string(o->flags), words[name], std::string(o->help));
    if (o->angle) option->transform(kAngle);
    if (o->check == MethodOption::Check::non_negative) option->check(kNonNegative);
    if (o->check == MethodOption::Check::positive) option->check(kPositive);
    if (o->check == MethodOption::Check::range) option->check(CLI::Range(o->min, o->max));
    if (!o->choices.empty())
      option->check(CLI::IsMember(std::vector<std::string>(o->choices.begin(), o->choices.end())));
    if (o->check_word)
      option->check([check = o->check_word](const std::string& v) { return check(v); });
    option->capture_default_str()->group("Filter");
  }
  cmd.add_option("--pops", pops,
                 "before the filter: repair pops (samples that jump away and come back) by "
                 "slerp; detect: only count them; auto: repair at 60 fps and more; from 20 to "
                 "60 fps (a 30 fps limb moves almost as fast as a pop) repair a clip where at "
                 "least 0.4 % of the samples are flagged; only count elsewhere; off: the spec's "
                 "filter exactly "
                 "(garbage joints neither looked for nor kept). Default: auto with --method "
                 "auto; off with a named method, which then is the spec's filter exactly")
      ->check(CLI::IsMember({"auto", "repair", "detect", "off"}))
      ->group("Cleaning");
  cmd.add_option("--garbage-joints", garbage_joints,
                 "joints that are constant, move only by float rounding or flip by ~pi "
                 "(uncaptured): keep them (out of nlpm's pose distance; constant and rounding "
                 "ones as they came, flipping ones filtered between their flips, which stay), "
                 "or filter them like the others (ignored with --pops off)")
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
                 "after the filter and the feet: a clip whose joint positions come out with "
                 "more jitter or more foot skating than they went in with (the clip as read, "
                 "over its own contacts; where the pop stage repaired samples, the repaired "
                 "clip, so that a pop's jitter cannot hide the filter's) falls back to the "
                 "filter without the lock, then to the input (pops repaired) locked, then to the "
                 "input, then to the clip as read, so cleaning never makes a capture worse on "
                 "what it can measure. Default: on with --method auto; off with a named method")
      ->check(CLI::IsMember({"on", "off"}))
      ->group("Cleaning");
  auto* split_on = cmd.add_flag(
      "--split-impossible", split_impossible_on,
      "filter separately the segments between physically impossible steps (a joint turning "
      "faster than min(150 rad/s x frame time, 2 rad) in one step, or the whole body: its joints' "
      "mean turn over max(0.2 rad, 4.5 rad/s x frame time); e.g. CMU's synthetic T-pose frame 0), "
      "so no filter smears such a jump. Default: on with --method auto, off with a "
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
  // Every method's parameters, whatever the method: auto's choice reads them (the boundary).
  for (const MethodEntry& e : method_entries())
    for (const MethodOption& o : e.options) {
      const std::string_view name = o.long_name();
      o.apply(s,
              o.type == MethodOption::Type::real      ? number(name)
              : o.type == MethodOption::Type::integer ? double(integer(name))
                                                      : 0.0,
              o.type == MethodOption::Type::word ? word(name) : std::string());
    }
  s.filter_translations = translations == "filter";
  // A named method is the spec's filter unless a pop stage is asked for; `auto` cleans fully.
  const PopsMode method_default =
      s.method == Method::automatic ? PopsMode::automatic : PopsMode::off;
  s.pops = pops.empty() ? method_default : parse_pops_mode(pops).value_or(method_default);
  s.keep_garbage_joints = garbage_joints == "keep";
  // On by default where the engine chooses anyway (auto): CMU's T-pose frame 0 stays a T-pose.
  s.split_impossible =
      split_impossible_on || (!split_impossible_off && s.method == Method::automatic);
  s.lock_feet = feet.empty() ? s.method == Method::automatic : feet == "lock";
  s.guard_motion = guard.empty() ? s.method == Method::automatic : guard == "on";
  s.shard_joints = shard_joints;
  s.shard_frames = shard_frames;
  return s;
}

std::vector<std::string> FilterOptions::warnings() const {
  // Angles are full rotation angles in rad; a value past these is almost surely degrees given
  // without "deg" (a bof range of pi/2 already treats every step as jitter).
  constexpr double kRadiansPerDegree = kPi / 180.0;
  std::vector<std::string> out;
  for (const MethodOption* o : distinct_options()) {
    if (!(o->implausible_above > 0)) continue;
    const std::string name(o->long_name());
    const std::optional<double> value = o->type == MethodOption::Type::real
                                            ? std::optional(number(name))
                                            : finite_number(word(name));  // off, auto: none
    if (value && *value > o->implausible_above)
      out.push_back(
          fmt::format("--{} {:g} rad ({:.4g} deg) is implausible: {}; for degrees write {:g}deg",
                      name, *value, *value / kRadiansPerDegree, o->implausible_why, *value));
  }
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
