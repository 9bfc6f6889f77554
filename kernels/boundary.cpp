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
    case Boundary::mirror: return "mirror";
    case Boundary::hold: return "hold";
    case Boundary::extrapolate: return "extrapolate";
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

Quat extended_rotation(RotationView rotations, int joint, long t, Boundary boundary) {
  const int frames = rotations.frames;
  if (boundary != Boundary::extrapolate || (t >= 0 && t < frames) || frames < 2)
    return load_quat(rotations.at(reflect_index(t, frames, boundary), joint));
  if (t < 0) {
    const Quat q0 = load_quat(rotations.at(0, joint));
    const Quat q1 = load_quat(rotations.at(1, joint));
    return q0 * exp(double(t) * log(inverse(q0) * q1));
  }
  const Quat qa = load_quat(rotations.at(frames - 2, joint));
  const Quat qb = load_quat(rotations.at(frames - 1, joint));
  return qb * exp(double(t - frames + 1) * log(inverse(qa) * qb));
}

Vec3 extended_translation(TranslationView translations, int joint, long t, Boundary boundary) {
  const int frames = translations.frames;
  if (boundary != Boundary::extrapolate || (t >= 0 && t < frames) || frames < 2)
    return load_vec3(translations.at(reflect_index(t, frames, boundary), joint));
  if (t < 0) {
    const Vec3 p0 = load_vec3(translations.at(0, joint));
    const Vec3 p1 = load_vec3(translations.at(1, joint));
    return p0 + double(t) * (p1 - p0);
  }
  const Vec3 pa = load_vec3(translations.at(frames - 2, joint));
  const Vec3 pb = load_vec3(translations.at(frames - 1, joint));
  return pb + double(t - frames + 1) * (pb - pa);
}

void extend_rotation_curve(RotationView rotations, int joint, int reach, Boundary boundary,
                           std::vector<Quat>& out) {
  out.resize(std::size_t(rotations.frames) + 2 * std::size_t(reach));
  for (long i = 0; i < long(out.size()); ++i)
    out[i] = extended_rotation(rotations, joint, i - reach, boundary);
}

void extend_translation_curve(TranslationView translations, int joint, int reach,
                              Boundary boundary, std::vector<Vec3>& out) {
  out.resize(std::size_t(translations.frames) + 2 * std::size_t(reach));
  for (long i = 0; i < long(out.size()); ++i)
    out[i] = extended_translation(translations, joint, i - reach, boundary);
}

void extend_rotation_curve(std::span<const Quat> curve, int reach, Boundary boundary,
                           std::vector<Quat>& out) {
  const int frames = int(curve.size());
  out.resize(curve.size() + 2 * std::size_t(reach));
  for (long i = 0; i < long(out.size()); ++i) {
    const long t = i - reach;
    if (boundary != Boundary::extrapolate || (t >= 0 && t < frames) || frames < 2) {
      out[i] = curve[reflect_index(t, frames, boundary)];
    } else if (t < 0) {
      out[i] = curve[0] * exp(double(t) * log(inverse(curve[0]) * curve[1]));
    } else {
      const Quat qa = curve[frames - 2], qb = curve[frames - 1];
      out[i] = qb * exp(double(t - frames + 1) * log(inverse(qa) * qb));
    }
  }
}

void extend_translation_curve(std::span<const Vec3> curve, int reach, Boundary boundary,
                              std::vector<Vec3>& out) {
  const int frames = int(curve.size());
  out.resize(curve.size() + 2 * std::size_t(reach));
  for (long i = 0; i < long(out.size()); ++i) {
    const long t = i - reach;
    if (boundary != Boundary::extrapolate || (t >= 0 && t < frames) || frames < 2) {
      out[i] = curve[reflect_index(t, frames, boundary)];
    } else if (t < 0) {
      out[i] = curve[0] + double(t) * (curve[1] - curve[0]);
    } else {
      const Vec3 pa = curve[frames - 2], pb = curve[frames - 1];
      out[i] = pb + double(t - frames + 1) * (pb - pa);
    }
  }
}

}  // namespace mocap
