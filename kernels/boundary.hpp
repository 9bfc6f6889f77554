#pragma once
// Boundary extension of ../shared/spec/filters.md, "Boundary extension": the samples a filter
// reads outside [0, F). Modes are named by behaviour.
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/quaternion.hpp"
#include "core/tensor.hpp"

namespace mocap {

enum class Boundary {
  mirror,       // q[-t], q[2(F-1) - t]; periodic with period 2(F-1) for long reaches
  hold,         // q[0], q[F-1]
  extrapolate,  // constant velocity from the first / last step
};

std::optional<Boundary> parse_boundary(std::string_view name);
std::string_view to_string(Boundary boundary);

// The in-range frame a mirror or hold read at `t` lands on (frames >= 1).
int reflect_index(long t, int frames, Boundary boundary);

// Sample `t` (any integer) of joint j's rotation curve, extended by the boundary mode.
// Requires frames >= 2 for extrapolate.
Quat extended_rotation(RotationView rotations, int joint, long t, Boundary boundary);
Vec3 extended_translation(TranslationView translations, int joint, long t, Boundary boundary);

// Joint j's curve over [-reach, F + reach): out[reach + t] is sample t.
void extend_rotation_curve(RotationView rotations, int joint, int reach, Boundary boundary,
                           std::vector<Quat>& out);
void extend_translation_curve(TranslationView translations, int joint, int reach, Boundary boundary,
                              std::vector<Vec3>& out);

// The same for a curve already held in double (one joint, F samples), e.g. the output of a
// filter's previous pass, which must not be rounded to float between passes.
void extend_rotation_curve(std::span<const Quat> curve, int reach, Boundary boundary,
                           std::vector<Quat>& out);
void extend_translation_curve(std::span<const Vec3> curve, int reach, Boundary boundary,
                              std::vector<Vec3>& out);

}  // namespace mocap
