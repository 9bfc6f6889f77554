#pragma once
// The masks of the linear orientation filters of ../shared/spec/filters.md, "Lee-Shin
// construction": gaussian, butterworth (zero-phase, designed here) and moving-mean. Each mask is
// m_{-k..k} (size 2k+1, m[r + k] is m_r) and sums to 1.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mocap {

enum class LinearKind { gaussian, butterworth, moving_mean };

// "gaussian", "butterworth", "moving-mean".
std::optional<LinearKind> parse_linear_kind(std::string_view name);
std::string_view to_string(LinearKind kind);

// k = ceil(3 sigma_t), the spec's default reach of a Gaussian of width sigma_t frames.
int default_gaussian_window(double sigma_t);

// m_r ~ exp(-r^2 / (2 sigma_t^2)), r in [-k, k], normalised. Requires sigma_t > 0, k >= 0.
std::vector<double> gaussian_mask(double sigma_t, int k);

// Blender's "Smooth Keys" weights (2, 3, 2, 3, 2) / 12.
std::vector<double> moving_mean_mask();

// One second-order section of a digital IIR filter:
//   y[n] = b0 x[n] + b1 x[n-1] + b2 x[n-2] - a1 y[n-1] - a2 y[n-2]
// (a first-order section has b2 = a2 = 0).
struct IirSection {
  double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
};

// The single-pass digital Butterworth low-pass of `order` whose -3 dB point is cutoff_hz, as
// scipy.signal.butter(order, cutoff / (fs/2)) designs it: analog prototype poles, prewarped
// cut-off, bilinear transform (zeros at z = -1), as cascaded sections with unit gain at DC.
// Requires 1 <= order and 0 < cutoff_hz < frame_rate_hz / 2.
std::vector<IirSection> butterworth_sections(int order, double cutoff_hz, double frame_rate_hz);

struct MaskResult {
  std::vector<double> mask;
  std::string error;  // empty on success
};

// The zero-phase (forward-backward) mask of the Butterworth low-pass above: the autocorrelation
// h_zp[r] = sum_n h[n] h[n + |r|] of its impulse response h, truncated after the last lag with
// |h_zp| >= 1e-6 of the peak, renormalised to sum 1. Errors: order outside [1, 8], cutoff <= 0,
// or cutoff >= 0.95 times the Nyquist frequency of frame_rate_hz (named in the message).
MaskResult butterworth_mask(int order, double cutoff_hz, double frame_rate_hz);
// What butterworth_mask would refuse, without designing the mask ("" = nothing).
std::string butterworth_mask_error(int order, double cutoff_hz, double frame_rate_hz);

}  // namespace mocap
