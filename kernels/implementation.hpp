#pragma once
// Which implementation of a kernel a job runs. The engine takes the default (fast); tests and
// the external accuracy check can ask for the scalar reference, the oracle of the fast path.
#include <optional>
#include <string_view>

namespace mocap {

enum class Implementation {
  fast,       // Highway SIMD, float32 lanes, dynamic dispatch (kernels/simd/)
  reference,  // scalar, double precision internally: the oracle
};

inline std::string_view to_string(Implementation implementation) {
  return implementation == Implementation::fast ? "fast" : "reference";
}

inline std::optional<Implementation> parse_implementation(std::string_view name) {
  if (name == "fast") return Implementation::fast;
  if (name == "reference") return Implementation::reference;
  return std::nullopt;
}

}  // namespace mocap
