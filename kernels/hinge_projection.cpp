#include "kernels/hinge_projection.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "kernels/pop_hinge.hpp"

namespace mocap {
namespace {

using Matrix3 = std::array<std::array<double, 3>, 3>;

// The eigenvalues of a symmetric 3x3 matrix, largest first, and the unit eigenvector of the
// largest: cyclic Jacobi rotations (a few sweeps reach double precision for 3x3).
std::pair<std::array<double, 3>, Vec3> eigen_symmetric(Matrix3 a) {
  Matrix3 v{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (!(off > 1e-30 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]))) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const double t = (theta >= 0 ? 1 : -1) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {  // A := A J (columns p, q)
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // A := J^T A (rows p, q)
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // V := V J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  std::array<int, 3> order{0, 1, 2};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      if (a[order[j]][order[j]] > a[order[i]][order[i]]) std::swap(order[i], order[j]);
  const int top = order[0];
  return {{a[order[0]][order[0]], a[order[1]][order[1]], a[order[2]][order[2]]},
          {v[0][top], v[1][top], v[2][top]}};
}

}  // namespace

Status HingeProjectionJob::validate() const {
  if (input.frames != output.frames || input.joints != output.joints)
    return Status::error("hinge projection: input and output differ in shape");
  if ((input.frames > 0 && input.joints > 0) && (!input.data || !output.data))
    return Status::error("hinge projection: input and output need samples");
  if (!skip.empty() && skip.size() != std::size_t(input.joints))
    return Status::error("hinge projection: skip must have one entry per joint");
  if (!projected.empty() && projected.size() != std::size_t(input.joints))
    return Status::error("hinge projection: projected must have one entry per joint");
  if (!std::isfinite(noise_sigma))
    return Status::error("hinge projection: noise_sigma must be finite");
  if (!(spread_over_noise > 0) || !std::isfinite(spread_over_noise) || !(motion_over_noise > 0) ||
      !std::isfinite(motion_over_noise))
    return Status::error("hinge projection: spread_over_noise and motion_over_noise must be > 0");
  if (min_frames < 3) return Status::error("hinge projection: min_frames must be at least 3");
  return {};
}

Status HingeProjectionJob::run() const {
  if (Status s = validate(); !s) return s;
  std::fill(projected.begin(), projected.end(), std::uint8_t{0});
  const int F = input.frames;
  if (!(noise_sigma > 0) || F < min_frames) return {};
  // The samples the statistics read: every stride-th, at most about 2 kHingeFitSamples of them.
  const int stride = std::max(1, F / kHingeFitSamples);
  std::vector<Quat> q;
  for (int j = 0; j < input.joints; ++j) {
    if (!skip.empty() && skip[std::size_t(j)]) continue;
    q.clear();
    Quat sum{0, 0, 0, 0};
    for (int t = 0; t < F; t += stride) {
      Quat s = load_quat(input.at(t, j));
      if (!q.empty() && dot(s, q[0]) < 0) s = negate(s);
      q.push_back(s);
      sum = {sum.w + s.w, sum.x + s.x, sum.y + s.y, sum.z + s.z};
    }
    if (!(std::sqrt(dot(sum, sum)) > 0)) continue;
    const Quat m = normalized(sum);
    const Quat back = inverse(m);
    const double n = double(q.size());
    const double limit = spread_over_noise * noise_sigma;
    const double motion = motion_over_noise * noise_sigma;
    // A screen first, on the chordal chart 2 vec(m^-1 q) (no arc tangent): each of its points is
    // the Log point drawn towards 0 by s = sin(phi / 2) / (phi / 2) in [s_min, 1] (phi its angle),
    // so its second moments lie between s_min^2 and 1 times Log's (Loewner order), and so do
    // their eigenvalues (Weyl): a chordal middle eigenvalue above limit^2, or a largest below
    // s_min^2 motion^2, rules the joint out as Log's would (most joints: those that turn about
    // several axes, and the still ones).
    Matrix3 chordal{};
    double widest = 0;
    for (const Quat& s : q) {
      const Quat rel = back * s;
      const double sign = rel.w < 0 ? -2.0 : 2.0;
      const double c[3] = {sign * rel.x, sign * rel.y, sign * rel.z};
      widest = std::max(widest, c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) chordal[r][k] += c[r] * c[k] / n;
    }
    const double half = std::asin(std::min(1.0, 0.5 * std::sqrt(widest)));  // phi / 2, widest
    const double s_min = half > 0 ? std::sin(half) / half : 1.0;
    const auto screened = eigen_symmetric(chordal).first;
    // Margins for the rounding of the two sums (relative 1e-9 on values of order 1).
    if (screened[1] > limit * limit * (1 + 1e-9) + 1e-15 ||
        screened[0] < s_min * s_min * motion * motion * (1 - 1e-9) - 1e-15)
      continue;
    Matrix3 moments{};
    for (const Quat& s : q) {
      const Vec3 v = log(back * s);
      const double c[3] = {v.x, v.y, v.z};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) moments[r][k] += c[r] * c[k] / n;
    }
    const auto [values, axis] = eigen_symmetric(moments);
    if (!(std::sqrt(std::max(values[1], 0.0)) <= limit) ||
        !(std::sqrt(std::max(values[0], 0.0)) >= motion))
      continue;
    Hinge hinge;
    hinge.found = true;
    hinge.axis = (1 / norm(axis)) * axis;
    hinge.reference = m;
    for (int t = 0; t < F; ++t)
      store_quat(project_onto_hinge(hinge, load_quat(output.at(t, j))), output.at(t, j));
    if (!projected.empty()) projected[std::size_t(j)] = 1;
  }
  return {};
}

}  // namespace mocap
