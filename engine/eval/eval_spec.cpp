#include "engine/eval/eval_spec.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

namespace mocap::engine::eval {
namespace {

// Comma-separated finite numbers; false on anything else.
bool parse_numbers(std::string_view text, std::vector<double>& out) {
  out.clear();
  while (!text.empty()) {
    const std::size_t comma = text.find(',');
    const std::string item(text.substr(0, comma));
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (...) {
      return false;
    }
    if (used != item.size() || !std::isfinite(v)) return false;
    out.push_back(v);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return !out.empty();
}

// Parameters that are two ways of setting the same thing: a grid names one or the other.
std::string_view alternative(std::string_view parameter) {
  if (parameter == "h") return "h_factor";
  if (parameter == "h_factor") return "h";
  if (parameter == "sigma_g") return "sigma_g_factor";
  if (parameter == "sigma_g_factor") return "sigma_g";
  if (parameter == "sigma_t") return "sigma_t_factor";
  if (parameter == "sigma_t_factor") return "sigma_t";
  if (parameter == "lambda") return "lambda_scale";
  if (parameter == "lambda_scale") return "lambda";
  return "";
}

}  // namespace

std::optional<EvalMethod> parse_eval_method(std::string_view name) {
  const std::span<const EvalVariant> variants = eval_variants();
  for (std::size_t i = 0; i < variants.size(); ++i)
    if (variants[i].name == name) return EvalMethod{int(i)};
  return std::nullopt;
}

std::string_view to_string(EvalMethod method) {
  return method.variant().name;
}

std::string label(const MethodGrid& grid) {
  std::string name(to_string(grid.method));
  if (grid.repaired && !grid.method.automatic()) name += "+pops";
  return grid.lock_feet ? name + "+feet" : name;
}

bool locked_twin(const std::vector<MethodGrid>& grids, std::size_t m) {
  return m > 0 && m < grids.size() && grids[m].lock_feet && !grids[m - 1].lock_feet &&
         grids[m - 1].method == grids[m].method && grids[m - 1].repaired == grids[m].repaired;
}

void apply_feet_mode(std::vector<MethodGrid>& grids, std::string_view mode) {
  if (mode == "lock") {
    for (MethodGrid& g : grids) g.lock_feet = true;
  } else if (mode == "both") {
    std::vector<MethodGrid> both;
    for (MethodGrid& g : grids) {
      MethodGrid locked{g.method, {}, g.repaired, true};
      both.push_back(std::move(g));
      both.push_back(std::move(locked));  // beside its twin in every table
    }
    grids = std::move(both);
  }
}

std::string NoiseCondition::label() const {
  const std::string positions =
      position_sigma > 0 ? fmt::format("+pos {:g}", position_sigma) : std::string();
  if (model == Model::gaussian) return fmt::format("gaussian {:g}{}", sigma, positions);
  return fmt::format("impulse {:g}{}", impulse.rate, positions);
}

namespace {
std::vector<NoiseCondition> parse_rotation_noise(std::string_view spec, std::string* error);
}  // namespace

std::vector<NoiseCondition> parse_noise(std::string_view spec, std::string* error) {
  const std::size_t plus = spec.find("+pos:");
  if (plus == std::string_view::npos) return parse_rotation_noise(spec, error);
  const std::string number(spec.substr(plus + 5));
  char* end = nullptr;
  const double fraction = std::strtod(number.c_str(), &end);
  if (number.empty() || end != number.c_str() + number.size() || !std::isfinite(fraction) ||
      fraction < 0 || fraction > 0.1) {
    *error = fmt::format(
        "--noise {}: +pos: takes the position noise as a fraction of the body's height in "
        "[0, 0.1], e.g. gaussian:0.02+pos:0.004",
        spec);
    return {};
  }
  std::vector<NoiseCondition> conditions = parse_rotation_noise(spec.substr(0, plus), error);
  for (NoiseCondition& c : conditions) c.position_sigma = fraction;
  return conditions;
}

namespace {
std::vector<NoiseCondition> parse_rotation_noise(std::string_view spec, std::string* error) {
  const std::size_t colon = spec.find(':');
  const std::string_view model = spec.substr(0, colon);
  const std::string_view rest =
      colon == std::string_view::npos ? std::string_view() : spec.substr(colon + 1);
  std::vector<double> values;
  std::vector<NoiseCondition> conditions;
  if (model == "gaussian") {
    if (!parse_numbers(rest, values)) {
      *error = fmt::format("--noise {}: give the levels, e.g. gaussian:0.008,0.03,0.12", spec);
      return {};
    }
    for (double sigma : values) {
      NoiseCondition c;
      c.sigma = sigma;
      if (const Status s = GaussianNoise{sigma, 1}.validate(); !s) {
        *error = fmt::format("--noise {}: {}", spec, s.message());
        return {};
      }
      conditions.push_back(c);
    }
    return conditions;
  }
  if (model == "impulse") {
    NoiseCondition c;
    c.model = NoiseCondition::Model::impulse;
    if (!rest.empty()) {
      if (!parse_numbers(rest, values) || (values.size() != 1 && values.size() != 3)) {
        *error = fmt::format("--noise {}: expected impulse or impulse:RATE[,MIN,MAX]", spec);
        return {};
      }
      c.impulse.rate = values[0];
      if (values.size() == 3) {
        c.impulse.min_angle = values[1];
        c.impulse.max_angle = values[2];
      }
    }
    if (const Status s = c.impulse.validate(); !s) {
      *error = fmt::format("--noise {}: {}", spec, s.message());
      return {};
    }
    conditions.push_back(c);
    return conditions;
  }
  *error = fmt::format("--noise {}: unknown noise model '{}' (gaussian or impulse)", spec, model);
  return {};
}

}  // namespace

std::vector<NoiseCondition> default_noise_conditions() {
  std::string ignored;
  std::vector<NoiseCondition> c = parse_noise("gaussian:0.008,0.03,0.12", &ignored);
  c.push_back(parse_noise("impulse", &ignored)[0]);
  return c;
}

std::string describe(const ParamPoint& point) {
  std::string text;
  for (const auto& [name, value] : point)
    text += fmt::format("{}{}={:g}", text.empty() ? "" : " ", name, value);
  return text;
}

std::vector<std::string> method_parameters(EvalMethod method) {
  return method.variant().parameters;
}

std::vector<GridAxis> default_axes(EvalMethod method) {
  return method.variant().axes;
}

std::optional<GridOverride> parse_grid_override(std::string_view spec, std::string* error) {
  const std::size_t dot = spec.find('.'), eq = spec.find('=');
  if (dot == std::string_view::npos || eq == std::string_view::npos || eq < dot) {
    *error = fmt::format("--grid {}: expected METHOD.PARAM=v1,v2,...", spec);
    return std::nullopt;
  }
  GridOverride g;
  const auto method = parse_eval_method(spec.substr(0, dot));
  if (!method) {
    *error = fmt::format("--grid {}: unknown method '{}'", spec, spec.substr(0, dot));
    return std::nullopt;
  }
  g.method = *method;
  g.axis.parameter = std::string(spec.substr(dot + 1, eq - dot - 1));
  const auto names = method_parameters(g.method);
  if (std::find(names.begin(), names.end(), g.axis.parameter) == names.end()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    *error = fmt::format("--grid {}: {} has no parameter '{}' (it has {})", spec,
                         to_string(g.method), g.axis.parameter, list);
    return std::nullopt;
  }
  if (!parse_numbers(spec.substr(eq + 1), g.axis.values)) {
    *error = fmt::format("--grid {}: the values must be numbers separated by commas", spec);
    return std::nullopt;
  }
  return g;
}

std::vector<MethodGrid> build_grids(const std::vector<EvalMethod>& methods,
                                    const std::vector<GridOverride>& overrides, bool with_plain,
                                    bool with_repaired) {
  std::vector<MethodGrid> grids;
  for (const bool repaired : {false, true})
    for (EvalMethod method : methods) {
      if (method.automatic() ? !repaired : repaired ? !with_repaired : !with_plain) continue;
      std::vector<GridAxis> axes = default_axes(method);
      for (const GridOverride& o : overrides) {
        if (o.method != method) continue;
        const std::string_view other = alternative(o.axis.parameter);
        std::erase_if(axes, [&](const GridAxis& a) {
          return a.parameter == o.axis.parameter || (!other.empty() && a.parameter == other);
        });
        axes.push_back(o.axis);
      }
      MethodGrid grid{method, {ParamPoint{}}, repaired};
      for (const GridAxis& axis : axes) {
        std::vector<ParamPoint> next;
        for (const ParamPoint& p : grid.points)
          for (double v : axis.values) {
            ParamPoint q = p;
            q.emplace_back(axis.parameter, v);
            next.push_back(std::move(q));
          }
        grid.points = std::move(next);
      }
      if (axes.empty()) grid.points.clear();  // no grid: the automatic parameters only
      grids.push_back(std::move(grid));
    }
  return grids;
}

}  // namespace mocap::engine::eval
