#pragma once
// The `kalman` baseline of the evaluation: a constant-velocity Rauch-Tung-Striebel smoother of
// each tangent component, applied to orientations through the Lee-Shin construction of
// ../shared/spec/filters.md ("Lee-Shin construction").
//
// Model, per tangent component and frame (time unit: one frame):
//     x_t = (angle, angular velocity),  x_{t+1} = F x_t + w_t,  F = [[1, 1], [0, 1]]
//     w_t ~ N(0, q [[1/3, 1/2], [1/2, 1]])   (white acceleration of density q, exact over a frame)
//     y_t = angle_t + v_t,  v_t ~ N(0, r)
// The smoother's gains depend on lambda = q / r only. Far from the ends of a clip the steady-state
// RTS smoother is a time-invariant linear filter whose impulse response is symmetric (it is the
// Wiener smoother q S(w) / (q S(w) + r) of the model, a real and even frequency response): that
// response, truncated after the last lag of magnitude >= 1e-6 of its peak and renormalised to sum
// 1 (as the spec truncates the butterworth mask), is the mask handed to Lee-Shin. For rotations
// about one fixed axis the filter is therefore the steady-state RTS smoother of the angle.
#include <span>
#include <vector>

#include "core/status.hpp"
#include "kernels/boundary.hpp"
#include "kernels/implementation.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

// Beyond these the mask is either longer than any clip (tens of thousands of frames) or a copy.
inline constexpr double kKalmanMinLambda = 1e-12;
inline constexpr double kKalmanMaxLambda = 1e6;

struct KalmanParams {
  // q / r: process noise (per frame^3) over measurement noise, no unit. 0 = not given: the caller
  // derives it (engine: kalman_auto_lambda). run() needs a lambda in range.
  double lambda = 0;
  Boundary boundary = Boundary::mirror;

  Status validate() const;  // lambda 0 (still to derive) or in [kKalmanMinLambda, kKalmanMaxLambda]
};

// The steady-state RTS smoother's mask m_{-k..k} (m[r + k] is m_r; symmetric, sums to 1).
// Requires a valid lambda.
std::vector<double> kalman_mask(double lambda);

// The textbook time-varying Kalman filter and RTS smoother of the same model on a scalar signal
// (diffuse prior: the first state is the first sample, with variances 1e8 r): out[t] is the
// smoothed angle. The oracle the mask is tested against; interior samples agree with the mask.
void rts_smooth(std::span<const double> signal, double lambda, std::span<double> out);

// The automatic lambda for a clip of estimated noise sigma_hat (rad, spec "Noise level
// estimate") and frame time dt (s):
//     lambda = kKalmanAutoScale (120 dt)^2.5 / sigma_hat^3
// calibrated on ../shared/data/bvh (120 fps) with added gaussian noise 0.008, 0.03, 0.12 rad
// (`mocap-clean eval`, docs/eval.md): the best lambda fell from about 3 to 0.001 over that range,
// as sigma_hat^-3, not as the model's own r = sigma_hat^2 (constant q) would say. The model
// assumes a motion spectrum falling as w^-4; captured motion falls more slowly (about w^-8/3 by
// this fit), and for such a spectrum the Wiener smoother's cut-off gives lambda ~ sigma^-3 and,
// in frames, ~ dt^2.5: the frame-rate factor follows from that argument (all the shared clips are
// 120 fps, so it is not measured). Clamped into [kKalmanMinLambda, kKalmanMaxLambda];
// sigma_hat <= 0 (nothing moves) gives kKalmanMaxLambda, a copy.
inline constexpr double kKalmanAutoScale = 1.1e-6;  // rad^3
// `scale` other than kKalmanAutoScale is for calibrating it.
double kalman_auto_lambda(double sigma_hat, double frame_time, double scale = kKalmanAutoScale);

struct KalmanJob {
  KalmanParams params;
  MotionIO io;
  // fast: the SIMD Lee-Shin passes (kernels/simd/lee_shin_simd.hpp, float32); reference: the
  // double pass of kernels/lee_shin.hpp. Translations of the marked joints get the same mask.
  Implementation implementation = Implementation::fast;

  Status validate() const;  // params.validate(), lambda > 0, io.validate()
  // Writes joints [io.joint_begin, io.joint_stop()) of frames [io.frame_begin, io.frame_stop()).
  Status run() const;
};

}  // namespace mocap
