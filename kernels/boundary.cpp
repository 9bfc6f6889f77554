#include "kernels/boundary.hpp"

namespace mocap {

std::optional<Boundary> parse_boundary(std::string_view name) {
  if (name == "mirror") return Boundary::mirror;
  if (name == "hold") return Boundary::hold;
  if (name == "extrapolate") return Boundary::extrapolate;
  return std::nullopt;
}

std::string_view to_string(Boundary boundary) {
  switch (boundary) {
    case Boundary::mirror:
      return "mirror";
    case Boundary::hold:
      return "hold";
    case Boundary::extrapolate:
      return "extrapolate";
  }
  return "?";
}

int reflect_index(long t, int frames, Boundary boundary) {
  const long last = frames - 1;
  if (t >= 0 && t <= last) return int(t);
  if (boundary != Boundary::mirror || frames == 1) return t < 0 ? 0 : int(last);
  const long period = 2 * last;
  long m = t % period;
  if (m < 0) m += period;
  return int(m <= last ? m : period - m);
}

namespace {

// Spec "extrapolate": `base` moved on by `steps` times the step from `from` to `to`.
Quat constant_velocity(Quat base, Quat from, Quat to, double steps) {
  return base * exp(steps * log(inverse(from) * to));
}
Vec3 constant_velocity(Vec3 base, Vec3 from, Vec3 to, double steps) {
  return base + steps * (to - from);
}

// Sample t (any integer) of a curve whose samples in [0, F) are sample(i).
template <class Sample>
auto extended(const Sample& sample, int frames, long t, Boundary boundary) {
  if (boundary != Boundary::extrapolate || (t >= 0 && t < frames) || frames < 2)
    return sample(reflect_index(t, frames, boundary));
  if (t < 0) return constant_velocity(sample(0), sample(0), sample(1), double(t));
  return constant_velocity(sample(frames - 1), sample(frames - 2), sample(frames - 1),
                           double(t - frames + 1));
}

template <class T, class Sample>
void extend_curve(const Sample& sample, int frames, int reach, Boundary boundary,
                  std::vector<T>& out) {
  out.resize(std::size_t(frames) + 2 * std::size_t(reach));
  for (long i = 0; i < long(out.size()); ++i)
    out[i] = extended(sample, frames, i - reach, boundary);
}

}  // namespace

Quat extended_rotation(RotationView rotations, int joint, long t, Boundary boundary) {
  return extended([&](long i) { return load_quat(rotations.at(int(i), joint)); }, rotations.frames,
                  t, boundary);
}

Vec3 extended_translation(TranslationView translations, int joint, long t, Boundary boundary) {
  return extended([&](long i) { return load_vec3(translations.at(int(i), joint)); },
                  translations.frames, t, boundary);
}

void extend_rotation_curve(RotationView rotations, int joint, int reach, Boundary boundary,
                           std::vector<Quat>& out) {
  extend_curve([&](long i) { return load_quat(rotations.at(int(i), joint)); }, rotations.frames,
               reach, boundary, out);
}

void extend_translation_curve(TranslationView translations, int joint, int reach, Boundary boundary,
                              std::vector<Vec3>& out) {
  extend_curve([&](long i) { return load_vec3(translations.at(int(i), joint)); },
               translations.frames, reach, boundary, out);
}

void extend_rotation_curve(std::span<const Quat> curve, int reach, Boundary boundary,
                           std::vector<Quat>& out) {
  extend_curve([&](long i) { return curve[std::size_t(i)]; }, int(curve.size()), reach, boundary,
               out);
}

void extend_translation_curve(std::span<const Vec3> curve, int reach, Boundary boundary,
                              std::vector<Vec3>& out) {
  extend_curve([&](long i) { return curve[std::size_t(i)]; }, int(curve.size()), reach, boundary,
               out);
}

}  // namespace mocap
