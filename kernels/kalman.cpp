#include "kernels/kalman.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/format.hpp"
#include "kernels/lee_shin.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/simd/lee_shin_simd.hpp"
#include "kernels/translation_filter.hpp"

namespace mocap {
namespace {

// A 2x2 matrix [[a, b], [c, d]] and a 2-vector: the state algebra of the constant-velocity model.
struct M2 {
  double a = 0, b = 0, c = 0, d = 0;
};
struct V2 {
  double p = 0, v = 0;
};

M2 operator+(M2 x, M2 y) {
  return {x.a + y.a, x.b + y.b, x.c + y.c, x.d + y.d};
}
M2 operator*(M2 x, M2 y) {
  return {x.a * y.a + x.b * y.c, x.a * y.b + x.b * y.d, x.c * y.a + x.d * y.c,
          x.c * y.b + x.d * y.d};
}
V2 operator*(M2 x, V2 y) {
  return {x.a * y.p + x.b * y.v, x.c * y.p + x.d * y.v};
}
V2 operator+(V2 x, V2 y) {
  return {x.p + y.p, x.v + y.v};
}
V2 operator-(V2 x, V2 y) {
  return {x.p - y.p, x.v - y.v};
}
V2 operator*(double s, V2 x) {
  return {s * x.p, s * x.v};
}
M2 transpose(M2 x) {
  return {x.a, x.c, x.b, x.d};
}
M2 inverse(M2 x) {
  const double det = x.a * x.d - x.b * x.c;
  return {x.d / det, -x.b / det, -x.c / det, x.a / det};
}

constexpr M2 kF{1, 1, 0, 1};
M2 process_noise(double lambda) {
  return {lambda / 3, lambda / 2, lambda / 2, lambda};
}

// The measurement update with r = 1 (only q / r matters): gain K and the filtered covariance.
struct Update {
  V2 gain;
  M2 filtered;
};
Update measurement_update(M2 predicted) {
  const double s = predicted.a + 1.0;
  const V2 k{predicted.a / s, predicted.c / s};
  return {k,
          {predicted.a - k.p * predicted.a, predicted.b - k.p * predicted.b,
           predicted.c - k.v * predicted.a, predicted.d - k.v * predicted.b}};
}

// The steady state of the Riccati recursion: the filter's gain K and the smoother's gain
// C = P_f F^T P_p^-1 once the covariances no longer change.
struct SteadyState {
  V2 gain;
  M2 smoother_gain;
};
SteadyState steady_state(double lambda) {
  const M2 q = process_noise(lambda);
  M2 predicted{1, 0, 0, 1};
  Update u = measurement_update(predicted);
  // Converges geometrically at the closed-loop pole, about 1 - lambda^(1/4) per step: a few
  // hundred thousand steps at kKalmanMinLambda, a handful at large lambda.
  for (int i = 0; i < 10'000'000; ++i) {
    const M2 next = kF * u.filtered * transpose(kF) + q;
    const double change = std::abs(next.a - predicted.a) + std::abs(next.b - predicted.b) +
                          std::abs(next.d - predicted.d);
    predicted = next;
    u = measurement_update(predicted);
    if (change <= 1e-15 * (std::abs(predicted.a) + std::abs(predicted.d))) break;
  }
  return {u.gain, u.filtered * transpose(kF) * inverse(predicted)};
}

// The steady-state smoother's response at every sample of y (forward filter from rest, then the
// backward RTS pass from the last filtered state).
void steady_state_smooth(const SteadyState& s, std::span<const double> y, std::span<double> out) {
  const std::size_t n = y.size();
  std::vector<V2> filtered(n);
  V2 x;
  for (std::size_t t = 0; t < n; ++t) {
    const V2 predicted = kF * x;
    x = predicted + (y[t] - predicted.p) * s.gain;
    filtered[t] = x;
  }
  V2 smoothed = filtered[n - 1];
  out[n - 1] = smoothed.p;
  for (std::size_t t = n - 1; t-- > 0;) {
    smoothed = filtered[t] + s.smoother_gain * (smoothed - kF * filtered[t]);
    out[t] = smoothed.p;
  }
}

}  // namespace

Status KalmanParams::validate() const {
  if (lambda != 0 && !(lambda >= kKalmanMinLambda && lambda <= kKalmanMaxLambda))
    return Status::error(format("kalman lambda must be in [1e-12, 1e6], got %g", lambda));
  switch (boundary) {
    case Boundary::mirror:
    case Boundary::hold:
    case Boundary::extrapolate:
      return {};
  }
  return Status::error("unknown boundary mode");
}

std::vector<double> kalman_mask(double lambda) {
  const SteadyState s = steady_state(lambda);
  // The impulse response of a unit sample at the centre of 2N+1 samples; N grows until the
  // response near both ends is far below the truncation level, so that neither the start from
  // rest nor the backward pass's start at the last filtered state reaches the kept lags.
  std::vector<double> impulse, response;
  for (int n = 64;; n *= 2) {
    impulse.assign(2 * std::size_t(n) + 1, 0.0);
    response.assign(impulse.size(), 0.0);
    impulse[std::size_t(n)] = 1.0;
    steady_state_smooth(s, impulse, response);
    const double peak = std::abs(response[std::size_t(n)]);
    double tail = 0;
    for (int i = 0; i < n / 4; ++i)
      tail = std::max({tail, std::abs(response[std::size_t(i)]),
                       std::abs(response[response.size() - 1 - std::size_t(i)])});
    if (tail <= 1e-10 * peak || n >= (1 << 22)) break;
  }
  // Correlation form: out_i = sum_r m_r y_{i+r}, so the response at sample n - r to the impulse
  // at n is m_r.
  const int n = int(response.size() / 2);
  const double peak = std::abs(response[std::size_t(n)]);
  int k = 0;
  for (int r = 1; r <= n; ++r)
    if (std::abs(response[std::size_t(n - r)]) >= 1e-6 * peak ||
        std::abs(response[std::size_t(n + r)]) >= 1e-6 * peak)
      k = r;
  std::vector<double> mask(2 * std::size_t(k) + 1);
  double sum = 0;
  for (int r = -k; r <= k; ++r) sum += mask[std::size_t(r + k)] = response[std::size_t(n - r)];
  for (double& m : mask) m /= sum;
  return mask;
}

void rts_smooth(std::span<const double> signal, double lambda, std::span<double> out) {
  const std::size_t n = signal.size();
  if (n == 0) return;
  const M2 q = process_noise(lambda);
  std::vector<V2> predicted_x(n), filtered_x(n);
  std::vector<M2> predicted_p(n), filtered_p(n);
  V2 x{signal[0], 0};
  M2 p{1e8, 0, 0, 1e8};
  for (std::size_t t = 0; t < n; ++t) {
    if (t > 0) {
      x = kF * x;
      p = kF * p * transpose(kF) + q;
    }
    predicted_x[t] = x;
    predicted_p[t] = p;
    const Update u = measurement_update(p);
    x = x + (signal[t] - x.p) * u.gain;
    p = u.filtered;
    filtered_x[t] = x;
    filtered_p[t] = p;
  }
  V2 smoothed = filtered_x[n - 1];
  out[n - 1] = smoothed.p;
  for (std::size_t t = n - 1; t-- > 0;) {
    const M2 c = filtered_p[t] * transpose(kF) * inverse(predicted_p[t + 1]);
    smoothed = filtered_x[t] + c * (smoothed - predicted_x[t + 1]);
    out[t] = smoothed.p;
  }
}

double kalman_auto_lambda(double sigma_hat, double frame_time, double scale) {
  if (!(sigma_hat > 0)) return kKalmanMaxLambda;
  const double lambda =
      scale * std::pow(120.0 * frame_time, 2.5) / (sigma_hat * sigma_hat * sigma_hat);
  return std::clamp(lambda, kKalmanMinLambda, kKalmanMaxLambda);
}

Status KalmanJob::validate() const {
  if (Status s = io.validate(); !s) return s;
  if (Status s = params.validate(); !s) return s;
  if (params.lambda == 0)
    return Status::error("kalman lambda must be > 0 (0, automatic, is resolved by the engine)");
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  return {};
}

Status KalmanJob::run() const {
  if (Status s = validate(); !s) return s;
  const std::vector<double> mask = kalman_mask(params.lambda);
  const int frames = io.rotations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  CurveScratch scratch;
  if (implementation == Implementation::fast) {
    simd::lee_shin_rotations(mask, 1, params.boundary, io);
  } else {
    std::vector<Quat> curve(frames), out(frames);
    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      for (int t = 0; t < frames; ++t) curve[t] = load_quat(io.rotations.at(t, j));
      linear_filter_rotations(curve, mask, 1, params.boundary, out, begin, end, scratch);
      for (int t = begin; t < end; ++t) store_quat(out[t], io.filtered_rotations.at(t, j));
    }
  }

  if (!io.has_translations()) return {};
  std::vector<Vec3> path(frames), path_out(frames);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    for (int t = 0; t < frames; ++t) path[t] = load_vec3(io.translations.at(t, j));
    if (io.translated_joints[j] != 0)
      linear_filter_translations(path, mask, 1, params.boundary, path_out, begin, end, scratch);
    else
      path_out = path;
    for (int t = begin; t < end; ++t) store_vec3(path_out[t], io.filtered_translations.at(t, j));
  }
  return {};
}

}  // namespace mocap
