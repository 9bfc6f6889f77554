#include "kernels/pop_hinge.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mocap {
namespace {

Vec3 vector_part(const Quat& q) {
  return {q.x, q.y, q.z};
}

// |v - (v . a) a|: the sine of half the angle by which a rotation of vector part v misses the
// axis a (header), compared with sin(tolerance / 2) so that no arc sine is taken per sample.
double off_axis_sine(Vec3 v, Vec3 axis) {
  return norm(v - dot(v, axis) * axis);
}

// Whether at least `needed` of the n items pass `on`: stops as soon as too many have failed (a
// noisy joint's candidates fail after about a tenth of their steps). `hopeless`: it failed with
// more items missed than passed.
template <class On>
bool at_least(std::size_t n, std::size_t needed, On on, bool* hopeless = nullptr) {
  if (hopeless) *hopeless = false;
  if (needed > n) return false;
  std::size_t misses = 0;
  const std::size_t allowed = n - needed;
  for (std::size_t i = 0; i < n; ++i)
    if (!on(i) && ++misses > allowed) {
      if (hopeless) *hopeless = misses > i + 1 - misses;
      return false;
    }
  return true;
}

// A first look at kHingeProbe steps of joint j around the clip's middle: true where every one of
// three of their moving steps has most of the others off its axis (a noisy joint, or one that
// turns about several axes), so that such a joint costs a few dozen steps instead of a pass over
// the clip. A hinge's pops (two steps each) leave most of its steps on the axis, so a probe that
// holds some is not ruled out; false too where the moving steps are too few to tell.
bool ruled_out_by_probe(RotationView rotations, int j, double limit) {
  const int F = rotations.frames;
  const int begin = std::max(0, F / 2 - kHingeProbe / 2),
            end = std::min(F - 1, begin + kHingeProbe);
  std::vector<Vec3> moving;
  for (int t = begin; t < end; ++t) {
    const Vec3 v =
        vector_part(inverse(load_quat(rotations.at(t, j))) * load_quat(rotations.at(t + 1, j)));
    if (norm(v) > limit) moving.push_back(v);
  }
  if (moving.size() < std::size_t(kHingeMinSteps)) return false;
  for (const std::size_t at : {moving.size() / 4, moving.size() / 2, 3 * moving.size() / 4}) {
    const Vec3 axis = (1 / norm(moving[at])) * moving[at];
    const auto on = std::count_if(moving.begin(), moving.end(),
                                  [&](Vec3 v) { return off_axis_sine(v, axis) <= limit; });
    if (2 * std::size_t(on) >= moving.size()) return false;
  }
  return true;
}

// The joint's hinge from its samples q (header): an axis that `share` of the moving steps lie on,
// and a reference sample that `share` of the samples lie on the curve of; found false where
// either is missing. The candidates are tried in a fixed order, the first that passes is taken.
Hinge find_hinge(const std::vector<Quat>& q, double tolerance, double share) {
  Hinge hinge;
  const std::size_t frames = q.size();
  if (frames < 3) return hinge;
  const double limit = std::sin(0.5 * tolerance);
  std::vector<Vec3> steps(frames - 1);
  std::vector<std::size_t> moving;
  for (std::size_t t = 0; t + 1 < frames; ++t) {
    steps[t] = vector_part(inverse(q[t]) * q[t + 1]);
    if (norm(steps[t]) > limit) moving.push_back(t);
  }
  if (moving.size() < std::size_t(kHingeMinSteps)) return hinge;
  const auto needed = [&](std::size_t n) { return std::size_t(std::ceil(share * double(n))); };
  // The axis: of candidate steps spread over the clip, the first that enough moving steps lie on.
  // Two candidates in a row that most steps miss: a noisy joint, or one that turns about several
  // axes (a hinge's candidate is a pop's step 2 % of the time).
  bool axis_found = false;
  int hopeless_in_a_row = 0;
  for (int k = 0; k < kHingeCandidates && !axis_found && hopeless_in_a_row < 2; ++k) {
    const Vec3 v = steps[moving[(2 * std::size_t(k) + 1) * moving.size() / (2 * kHingeCandidates)]];
    hinge.axis = (1 / norm(v)) * v;
    bool hopeless = false;
    axis_found = at_least(
        moving.size(), needed(moving.size()),
        [&](std::size_t i) { return off_axis_sine(steps[moving[i]], hinge.axis) <= limit; },
        &hopeless);
    hopeless_in_a_row = hopeless ? hopeless_in_a_row + 1 : 0;
  }
  if (!axis_found) return hinge;
  // The reference: of the samples between two steps on the axis, spread over the clip, the first
  // that enough samples lie on the curve of (all of an exact hinge's do).
  std::vector<std::size_t> between;
  for (std::size_t t = 1; t + 1 < frames; ++t)
    if (off_axis_sine(steps[t - 1], hinge.axis) <= limit &&
        off_axis_sine(steps[t], hinge.axis) <= limit)
      between.push_back(t);
  for (int k = 0; k < kHingeCandidates && !between.empty() && !hinge.found; ++k) {
    hinge.reference =
        q[between[(2 * std::size_t(k) + 1) * between.size() / (2 * kHingeCandidates)]];
    const Quat back = inverse(hinge.reference);
    hinge.found = at_least(frames, needed(frames), [&](std::size_t t) {
      return off_axis_sine(vector_part(back * q[t]), hinge.axis) <= limit;
    });
  }
  return hinge;
}

}  // namespace

double hinge_distance(const Hinge& hinge, const Quat& q) {
  return 2 * std::asin(std::min(
                 1.0, off_axis_sine(vector_part(inverse(hinge.reference) * q), hinge.axis)));
}

Quat project_onto_hinge(const Hinge& hinge, const Quat& q) {
  const Quat relative = inverse(hinge.reference) * q;
  const double along = dot(vector_part(relative), hinge.axis);
  const double length = std::hypot(relative.w, along);
  if (!(length > 0)) return q;  // a half turn off the axis: no nearest point
  const Vec3 v = (along / length) * hinge.axis;
  return hinge.reference * Quat{relative.w / length, v.x, v.y, v.z};
}

Status PopHingeJob::validate() const {
  if (Status s = validate_sample_flags("pop hinge test", rotations, skip, flags); !s) return s;
  if (!(tolerance > 0) || !std::isfinite(tolerance))
    return Status::error("pop hinge test: tolerance must be a finite angle > 0 rad");
  if (!(share > 0 && share <= 1)) return Status::error("pop hinge test: share must lie in (0, 1]");
  if (max_run < 1) return Status::error("pop hinge test: max_run must be at least 1 frame");
  if (!(pop_angle >= tolerance) || !std::isfinite(pop_angle))
    return Status::error("pop hinge test: pop_angle must be a finite angle >= tolerance");
  if (Status s = validate_joint_slice("pop hinge test", joint_begin, joint_end, rotations.joints);
      !s)
    return s;
  if (!hinges.empty() && hinges.size() != std::size_t(rotations.joints))
    return Status::error("pop hinge test: hinges must have one entry per joint");
  return {};
}

Status PopHingeJob::run() const {
  if (Status s = validate(); !s) return s;
  const int F = rotations.frames, J = rotations.joints;
  const int end = joint_end < 0 ? J : joint_end;
  const double limit = std::sin(0.5 * tolerance);  // off_axis_sine's bound for `tolerance`
  std::vector<Quat> q(std::size_t(std::max(F, 0)));
  for (int j = joint_begin; j < end; ++j) {
    if (!hinges.empty()) hinges[std::size_t(j)] = {};
    if (!skip.empty() && skip[std::size_t(j)]) continue;
    if (ruled_out_by_probe(rotations, j, limit)) continue;
    for (int t = 0; t < F; ++t) q[std::size_t(t)] = load_quat(rotations.at(t, j));
    const Hinge hinge = find_hinge(q, tolerance, share);
    if (!hinges.empty()) hinges[std::size_t(j)] = hinge;
    if (!hinge.found) continue;
    // Runs of samples off the curve; the short ones are pops.
    const Quat back = inverse(hinge.reference);
    const auto off = [&](int t) {
      return off_axis_sine(vector_part(back * q[std::size_t(t)]), hinge.axis) > limit;
    };
    for (int t = 0; t < F;) {
      if (!off(t)) {
        ++t;
        continue;
      }
      int e = t;
      while (e + 1 < F && off(e + 1)) ++e;
      double farthest = 0;
      for (int s = t; s <= e; ++s)
        farthest = std::max(farthest, hinge_distance(hinge, q[std::size_t(s)]));
      if (e - t + 1 <= max_run && farthest > pop_angle)
        for (int s = t; s <= e; ++s) flags[std::size_t(s) * std::size_t(J) + std::size_t(j)] = 1;
      t = e + 1;
    }
  }
  return {};
}

}  // namespace mocap
