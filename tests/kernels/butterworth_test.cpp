// Tests of the Butterworth design and its zero-phase mask (spec "Lee-Shin construction",
// butterworth): the single pass is the bilinear-transform design of scipy.signal.butter, the mask
// is the impulse response of an actual forward-backward run, truncated after the last lag >= 1e-6
// of the peak, and its spectrum is |H|^2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <vector>

#include "kernels/linear_masks.hpp"

namespace mocap {
namespace {

constexpr double kPiD = 3.14159265358979323846;

// The section cascade as one direct-form polynomial pair b(z^-1), a(z^-1) with a[0] = 1.
struct DirectForm {
  std::vector<double> b{1.0}, a{1.0};
};

std::vector<double> multiply(const std::vector<double>& p, const std::vector<double>& q) {
  std::vector<double> out(p.size() + q.size() - 1, 0.0);
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = 0; j < q.size(); ++j) out[i + j] += p[i] * q[j];
  return out;
}

DirectForm direct_form(const std::vector<IirSection>& sections) {
  DirectForm f;
  for (const IirSection& s : sections) {
    f.b = multiply(f.b, {s.b0, s.b1, s.b2});
    f.a = multiply(f.a, {1.0, s.a1, s.a2});
  }
  return f;
}

// The IIR difference equation a[0] y[n] = sum b[i] x[n-i] - sum_{i>0} a[i] y[n-i], run forward.
std::vector<double> difference_equation(const DirectForm& f, const std::vector<double>& x) {
  std::vector<double> y(x.size(), 0.0);
  for (std::size_t n = 0; n < x.size(); ++n) {
    double acc = 0;
    for (std::size_t i = 0; i < f.b.size() && i <= n; ++i) acc += f.b[i] * x[n - i];
    for (std::size_t i = 1; i < f.a.size() && i <= n; ++i) acc -= f.a[i] * y[n - i];
    y[n] = acc;
  }
  return y;
}

// Single-pass frequency response H(e^{i omega}) of the cascade.
std::complex<double> response(const std::vector<IirSection>& sections, double omega) {
  const std::complex<double> z1 = std::polar(1.0, -omega);  // z^-1
  std::complex<double> h = 1.0;
  for (const IirSection& s : sections)
    h *= (s.b0 + s.b1 * z1 + s.b2 * z1 * z1) / (1.0 + s.a1 * z1 + s.a2 * z1 * z1);
  return h;
}

// The Butterworth magnitude after the bilinear transform with prewarping:
// |H(f)|^2 = 1 / (1 + (tan(pi f / fs) / tan(pi fc / fs))^(2n)).
double butterworth_power(int order, double f, double fc, double fs) {
  return 1.0 / (1.0 + std::pow(std::tan(kPiD * f / fs) / std::tan(kPiD * fc / fs), 2 * order));
}

double mask_spectrum(const std::vector<double>& mask, double omega) {
  const int k = int(mask.size() / 2);
  double sum = 0;
  for (int r = -k; r <= k; ++r) sum += mask[r + k] * std::cos(omega * r);
  return sum;
}

struct Design {
  int order;
  double cutoff, rate;
};
const Design kDesigns[] = {{2, 6.0, 120.0}, {1, 6.0, 120.0}, {4, 10.0, 60.0},
                           {8, 6.0, 120.0}, {3, 2.0, 30.0},  {2, 0.5, 120.0}};

TEST(Butterworth, SecondOrderMatchesTheClosedFormBilinearBiquad) {
  // Textbook bilinear Butterworth biquad with K = tan(pi fc / fs):
  // b = K^2 (1, 2, 1) / D, a = (1, 2 (K^2 - 1) / D, (1 - sqrt2 K + K^2) / D), D = 1 + sqrt2 K +
  // K^2.
  for (double fc : {1.0, 6.0, 20.0, 50.0}) {
    const double fs = 120.0, k = std::tan(kPiD * fc / fs), d = 1 + std::sqrt(2.0) * k + k * k;
    const DirectForm f = direct_form(butterworth_sections(2, fc, fs));
    ASSERT_EQ(f.b.size(), 3u);
    EXPECT_NEAR(f.b[0], k * k / d, 1e-14);
    EXPECT_NEAR(f.b[1], 2 * k * k / d, 1e-14);
    EXPECT_NEAR(f.b[2], k * k / d, 1e-14);
    EXPECT_NEAR(f.a[1], 2 * (k * k - 1) / d, 1e-14);
    EXPECT_NEAR(f.a[2], (1 - std::sqrt(2.0) * k + k * k) / d, 1e-14);
  }
}

TEST(Butterworth, SinglePassHasTheButterworthMagnitudeAndMinus3dBAtTheCutoff) {
  for (const Design& d : kDesigns) {
    const std::vector<IirSection> sections = butterworth_sections(d.order, d.cutoff, d.rate);
    const double at_cutoff = std::abs(response(sections, 2 * kPiD * d.cutoff / d.rate));
    EXPECT_NEAR(at_cutoff, 1 / std::sqrt(2.0), 1e-12) << "order " << d.order;
    EXPECT_NEAR(std::abs(response(sections, 0.0)), 1.0, 1e-12);
    for (double f : {0.1, 0.5, 0.9, 1.3, 2.0, 4.0}) {
      const double hz = f * d.cutoff;
      if (hz >= d.rate / 2) continue;
      EXPECT_NEAR(std::norm(response(sections, 2 * kPiD * hz / d.rate)),
                  butterworth_power(d.order, hz, d.cutoff, d.rate), 1e-12)
          << "order " << d.order << " at " << hz << " Hz";
    }
  }
}

// The impulse response of the forward-backward run: a unit impulse in the middle of a long zero
// signal (index `half`), filtered forward then backward with the difference equation.
std::vector<double> forward_backward_impulse(const Design& d, int half) {
  const DirectForm f = direct_form(butterworth_sections(d.order, d.cutoff, d.rate));
  std::vector<double> x(2 * std::size_t(half) + 1, 0.0);
  x[half] = 1.0;
  std::vector<double> y = difference_equation(f, x);
  std::reverse(y.begin(), y.end());
  y = difference_equation(f, y);
  std::reverse(y.begin(), y.end());
  return y;
}

TEST(Butterworth, MaskIsTheTruncatedForwardBackwardImpulseResponse) {
  for (const Design& d : kDesigns) {
    const MaskResult result = butterworth_mask(d.order, d.cutoff, d.rate);
    ASSERT_TRUE(result.error.empty()) << result.error;
    const std::vector<double>& mask = result.mask;
    ASSERT_EQ(mask.size() % 2, 1u);
    const int k = int(mask.size() / 2);

    const int half = 4 * k + 2000;
    const std::vector<double> y = forward_backward_impulse(d, half);

    double peak = 0;
    for (double v : y) peak = std::max(peak, std::abs(v));
    EXPECT_NEAR(peak, y[half], 1e-15);  // the peak is at lag 0
    // Truncated after the last lag that still reaches 1e-6 of the peak.
    EXPECT_GE(std::abs(y[half + k]), 1e-6 * peak) << "order " << d.order;
    for (int r = k + 1; r <= half; ++r)
      ASSERT_LT(std::abs(y[half + r]), 1e-6 * peak) << "order " << d.order << " lag " << r;
    double kept = 0;
    for (int r = -k; r <= k; ++r) kept += y[half + r];
    for (int r = -k; r <= k; ++r)
      EXPECT_NEAR(mask[r + k], y[half + r] / kept, 1e-9)
          << "order " << d.order << " cutoff " << d.cutoff << " lag " << r;
  }
}

TEST(Butterworth, MaskSpectrumIsTheSquaredMagnitude) {
  for (const Design& d : kDesigns) {
    const std::vector<double> mask = butterworth_mask(d.order, d.cutoff, d.rate).mask;
    const int k = int(mask.size() / 2);
    double sum = 0;
    for (double m : mask) sum += m;
    EXPECT_NEAR(sum, 1.0, 1e-12);
    for (std::size_t r = 0; r < mask.size(); ++r) EXPECT_EQ(mask[r], mask[mask.size() - 1 - r]);
    // Up to truncation: the full response has spectrum |H|^2 exactly; dropping lags beyond k
    // (total magnitude `tail`) and renormalising moves it by at most 2 tail / (1 - tail).
    const int half = 4 * k + 2000;
    const std::vector<double> y = forward_backward_impulse(d, half);
    double tail = 0;
    for (int r = k + 1; r <= half; ++r) tail += 2 * std::abs(y[half + r]);
    ASSERT_LT(tail, 1e-3) << "order " << d.order;
    const double tolerance = 2 * tail / (1 - tail) + 1e-12;
    // -6 dB at the cut-off after both passes; |H|^2 elsewhere.
    EXPECT_NEAR(mask_spectrum(mask, 2 * kPiD * d.cutoff / d.rate), 0.5, tolerance);
    for (double f : {0.25, 0.5, 0.8, 1.2, 1.6, 2.5, 3.5}) {
      const double hz = f * d.cutoff;
      if (hz >= d.rate / 2) continue;
      EXPECT_NEAR(mask_spectrum(mask, 2 * kPiD * hz / d.rate),
                  butterworth_power(d.order, hz, d.cutoff, d.rate), tolerance)
          << "order " << d.order << " at " << hz << " Hz";
    }
  }
}

TEST(Butterworth, RejectsCutoffsNearNyquistNamingTheFrameRate) {
  const MaskResult near = butterworth_mask(2, 58.0, 120.0);
  EXPECT_TRUE(near.mask.empty());
  EXPECT_EQ(near.error,
            "cutoff 58 Hz is too close to the Nyquist frequency of this clip's 120.00 fps (must be "
            "below 57 Hz)");
  // A frame time written as 0.0333333 is 30.00003 fps: 14.3 Hz is above 0.95 * 15.
  const MaskResult thirty = butterworth_mask(2, 14.3, 1.0 / 0.0333333);
  EXPECT_NE(thirty.error.find("30.00 fps"), std::string::npos) << thirty.error;
  EXPECT_TRUE(butterworth_mask(2, 14.2, 1.0 / 0.0333333).error.empty());
  EXPECT_EQ(butterworth_mask(2, 0.0, 120.0).error, "cutoff must be > 0 Hz, got 0");
  EXPECT_EQ(butterworth_mask(9, 6.0, 120.0).error, "butterworth order must be in [1, 8], got 9");
  EXPECT_EQ(butterworth_mask(0, 6.0, 120.0).error, "butterworth order must be in [1, 8], got 0");
}

TEST(Butterworth, LowerCutoffGivesALongerMask) {
  // The response decays with the pole radius: halving the cut-off roughly doubles the reach.
  const std::size_t wide = butterworth_mask(2, 12.0, 120.0).mask.size();
  const std::size_t narrow = butterworth_mask(2, 6.0, 120.0).mask.size();
  EXPECT_GT(narrow, wide + wide / 2);
}

}  // namespace
}  // namespace mocap
