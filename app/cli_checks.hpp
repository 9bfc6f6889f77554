#pragma once
// Checks of numeric options with messages a user can act on ("--sigma-t: must be a number > 0,
// got -1"), in place of CLI11's PositiveNumber / NonNegativeNumber, whose messages print the
// range up to DBL_MAX in full.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

namespace mocap::engine {

// The whole of `text` as a finite number, else nullopt.
inline std::optional<double> finite_number(const std::string& text) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(x)) return std::nullopt;
  return x;
}

namespace detail {
inline CLI::Validator number_check(bool allow_zero, const char* name) {
  return CLI::Validator(
      [allow_zero](std::string& value) -> std::string {
        const std::optional<double> x = finite_number(value);
        if (x && (*x > 0 || (allow_zero && *x == 0))) return "";
        return std::string("must be a number ") + (allow_zero ? ">= 0" : "> 0") + ", got '" +
               value + "'";
      },
      name, name);
}
}  // namespace detail

inline const CLI::Validator kPositive = detail::number_check(false, "POSITIVE");
inline const CLI::Validator kNonNegative = detail::number_check(true, "NONNEGATIVE");

// An angle in radians, or in degrees with a "deg" suffix ("10deg", "10 deg"; "rad" is accepted
// too): the value is rewritten in radians before the number checks run. Other text is left as
// it is, for the checks to refuse.
inline const CLI::Validator kAngle = CLI::Validator(
    [](std::string& value) -> std::string {
      auto strip = [&](const char* suffix) {
        const std::string s(suffix);
        if (value.size() <= s.size() || value.compare(value.size() - s.size(), s.size(), s) != 0)
          return false;
        value.resize(value.size() - s.size());
        while (!value.empty() && value.back() == ' ') value.pop_back();
        return true;
      };
      if (strip("deg")) {
        if (const std::optional<double> x = finite_number(value)) {
          char buffer[40];
          std::snprintf(buffer, sizeof buffer, "%.17g", *x * (3.14159265358979323846 / 180.0));
          value = buffer;
        } else {
          value += "deg";  // not a number: left for the number check to name
        }
      } else {
        strip("rad");
      }
      return "";
    },
    "ANGLE (rad, or e.g. 10deg)", "ANGLE");

}  // namespace mocap::engine
