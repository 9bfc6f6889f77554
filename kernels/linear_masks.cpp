#include "kernels/linear_masks.hpp"
#include "core/format.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

namespace mocap {
namespace {

constexpr double kPiD = 3.14159265358979323846;

void normalise(std::vector<double>& mask) {
  double sum = 0;
  for (double m : mask) sum += m;
  for (double& m : mask) m /= sum;
}

// Streams a signal through the cascade, one sample at a time (transposed direct form II).
class Cascade {
 public:
  explicit Cascade(const std::vector<IirSection>& sections)
      : sections_(sections), state_(sections.size()) {}
  double step(double x) {
    for (std::size_t s = 0; s < sections_.size(); ++s) {
      const IirSection& c = sections_[s];
      auto& [s1, s2] = state_[s];
      const double y = c.b0 * x + s1;
      s1 = c.b1 * x - c.a1 * y + s2;
      s2 = c.b2 * x - c.a2 * y;
      x = y;
    }
    return x;
  }

 private:
  const std::vector<IirSection>& sections_;
  std::vector<std::pair<double, double>> state_;
};

// Largest pole radius of the cascade: the decay rate of its impulse response.
double pole_radius(const std::vector<IirSection>& sections) {
  double rho = 0;
  for (const IirSection& c : sections)
    rho = std::max(rho, c.a2 != 0 ? std::sqrt(std::abs(c.a2)) : std::abs(c.a1));
  return rho;
}

constexpr std::size_t kMaxResponseLength = std::size_t(1) << 22;

}  // namespace

std::optional<LinearKind> parse_linear_kind(std::string_view name) {
  if (name == "gaussian") return LinearKind::gaussian;
  if (name == "butterworth") return LinearKind::butterworth;
  if (name == "moving-mean") return LinearKind::moving_mean;
  return std::nullopt;
}

std::string_view to_string(LinearKind kind) {
  switch (kind) {
    case LinearKind::gaussian:
      return "gaussian";
    case LinearKind::butterworth:
      return "butterworth";
    case LinearKind::moving_mean:
      return "moving-mean";
  }
  return "?";
}

int default_gaussian_window(double sigma_t) {
  return int(std::ceil(3.0 * sigma_t));
}

std::vector<double> gaussian_mask(double sigma_t, int k) {
  std::vector<double> mask(2 * std::size_t(k) + 1);
  for (int r = -k; r <= k; ++r) mask[r + k] = std::exp(-double(r) * r / (2 * sigma_t * sigma_t));
  normalise(mask);
  return mask;
}

std::vector<double> moving_mean_mask() {
  return {2.0 / 12, 3.0 / 12, 2.0 / 12, 3.0 / 12, 2.0 / 12};
}

std::vector<IirSection> butterworth_sections(int order, double cutoff_hz, double frame_rate_hz) {
  // Analog prototype poles p = exp(i pi (2m + n - 1) / (2n)), m = 1..n, on the left unit half
  // circle; the prewarped cut-off scales them by 2 fs tan(pi fc / fs), and the bilinear transform
  // z = (2 fs + s) / (2 fs - s) maps them to z = (1 + t p) / (1 - t p) with t = tan(pi fc / fs).
  const double t = std::tan(kPiD * cutoff_hz / frame_rate_hz);
  std::vector<IirSection> sections;
  for (int m = 1; 2 * m <= order; ++m) {  // conjugate pairs: p_m and p_{n+1-m}
    const std::complex<double> p = std::polar(1.0, kPiD * (2 * m + order - 1) / (2.0 * order));
    const std::complex<double> z = (1.0 + t * p) / (1.0 - t * p);
    IirSection c;
    c.a1 = -2 * z.real();
    c.a2 = std::norm(z);
    const double gain = (1 + c.a1 + c.a2) / 4;  // zeros (1 + z^-1)^2, unit gain at z = 1
    c.b0 = gain;
    c.b1 = 2 * gain;
    c.b2 = gain;
    sections.push_back(c);
  }
  if (order % 2 == 1) {  // the real pole p = -1
    const double z = (1 - t) / (1 + t);
    IirSection c;
    c.a1 = -z;
    c.b0 = c.b1 = (1 - z) / 2;
    sections.push_back(c);
  }
  return sections;
}

std::string butterworth_mask_error(int order, double cutoff_hz, double frame_rate_hz) {
  if (order < 1 || order > 8) return format("butterworth order must be in [1, 8], got %d", order);
  if (!(frame_rate_hz > 0) || !std::isfinite(frame_rate_hz))
    return format("frame rate must be > 0, got %g fps", frame_rate_hz);
  if (!(cutoff_hz > 0)) return format("cutoff must be > 0 Hz, got %g", cutoff_hz);
  // Closer to Nyquist the poles approach the unit circle and the response never decays.
  const double limit = 0.95 * frame_rate_hz / 2;
  if (!(cutoff_hz < limit))
    return format(
        "cutoff %g Hz is too close to the Nyquist frequency of this clip's %.2f fps (must be "
        "below %.6g Hz)",
        cutoff_hz, frame_rate_hz, limit);
  return {};
}

MaskResult butterworth_mask(int order, double cutoff_hz, double frame_rate_hz) {
  MaskResult result;
  result.error = butterworth_mask_error(order, cutoff_hz, frame_rate_hz);
  if (!result.error.empty()) return result;
  const std::vector<IirSection> sections = butterworth_sections(order, cutoff_hz, frame_rate_hz);

  // Single-pass impulse response h, run until it has decayed below 1e-18 of its peak for long
  // enough (several time constants 1 / (1 - rho), which also spans a full ringing period).
  const double rho = pole_radius(sections);
  const double min_length = std::log(1e-18) / std::log(rho);
  const double quiet_needed = 8.0 / (1.0 - rho) + 16;
  std::vector<double> h;
  {
    Cascade forward(sections);
    double peak = 0;
    std::size_t quiet = 0;
    for (std::size_t n = 0;; ++n) {
      const double y = forward.step(n == 0 ? 1.0 : 0.0);
      h.push_back(y);
      peak = std::max(peak, std::abs(y));
      quiet = std::abs(y) < 1e-18 * peak ? quiet + 1 : 0;
      if (double(n) >= min_length && double(quiet) >= quiet_needed) break;
      if (h.size() >= kMaxResponseLength) {
        result.error = format(
            "cutoff %g Hz is too low for a butterworth filter at %.2f fps: its response does not "
            "decay within %g frames",
            cutoff_hz, frame_rate_hz, double(kMaxResponseLength));
        return result;
      }
    }
  }

  // h_zp[r] = sum_n h[n] h[n + r] is the backward pass of the filter over h: run the cascade
  // over h reversed; sample L-1-r of that output is lag r.
  const std::size_t length = h.size();
  std::vector<double> zero_phase(length);
  {
    Cascade backward(sections);
    for (std::size_t i = 0; i < length; ++i)
      zero_phase[length - 1 - i] = backward.step(h[length - 1 - i]);
  }
  double peak = 0;
  for (double v : zero_phase) peak = std::max(peak, std::abs(v));
  // The response rings: keep everything up to the last lag that is still >= 1e-6 of the peak.
  std::size_t k = 0;
  for (std::size_t r = 0; r < length; ++r)
    if (std::abs(zero_phase[r]) >= 1e-6 * peak) k = r;

  result.mask.resize(2 * k + 1);
  for (std::size_t r = 0; r <= k; ++r) result.mask[k + r] = result.mask[k - r] = zero_phase[r];
  normalise(result.mask);
  return result;
}

}  // namespace mocap
