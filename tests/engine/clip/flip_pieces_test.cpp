// Flipping joints filtered between their flips (engine/clip/flip_pieces.hpp): the pieces are cut
// at the flips and nowhere else, each piece comes out smoother, the flips stay where they were,
// nothing else is written, and auto filters them with its bof or not at all.
#include "engine/clip/flip_pieces.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "engine/clip/methods.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap::engine {
namespace {

constexpr int kFrames = 240, kJoints = 3, kFlipper = 1;
const int kFlips[] = {70, 131, 200};  // the steps t -> t + 1 that flip

// Smooth motion on every joint; joint kFlipper turned by pi - 0.05 rad about x on the frames
// after an odd number of flips (an uncaptured joint whose Euler channels flip).
test::Motion flipping_motion() {
  std::mt19937_64 rng(41);
  test::Motion m{kFrames, kJoints, test::random_motion(rng, kFrames, kJoints, 0.5)};
  const Quat flip = exp(Vec3{3.14159265358979 - 0.05, 0, 0});
  for (int t = 0; t < kFrames; ++t) {
    int flips = 0;
    for (int f : kFlips) flips += t > f;
    if (flips % 2) store_quat(m.at(t, kFlipper) * flip, m.span().at(t, kFlipper));
  }
  return m;
}

// Bof at three frames, one pass, range weight wide enough for the noise below; or the linear
// Gaussian filter (sigma_t 2 frames), which has no range weight to stop at a flip.
FilterSettings settings_of(Method method) {
  FilterSettings s;
  s.method = method;
  if (method == Method::bof) {
    BilateralParams& b = s.edit<BilateralParams>();
    b.sigma_t = 3;
    b.sigma_g = 0.3;
    b.iterations = 1;
  } else {
    s.edit<LinearParams>().sigma_t = 2;
  }
  return s;
}

// The flipping joint of `in` filtered between its flips into `out` (every other joint left as
// `out` holds it).
Status filter_flipper(const FilterSettings& settings, const test::Motion& in, test::Motion& out) {
  MotionIO io;
  io.rotations = in.view();
  io.filtered_rotations = out.span();
  return filter_between_flips(settings, io, kFlipper, {});
}

double piece_rms(const test::Motion& a, const test::Motion& b, int begin, int end) {
  double sum = 0;
  for (int t = begin; t < end; ++t)
    sum += std::pow(test::rotation_error(a.view(), b.view(), t, kFlipper), 2);
  return std::sqrt(sum / (end - begin));
}

TEST(FlipPieces, CutAfterEachFlipAndNowhereElse) {
  const test::Motion m = flipping_motion();
  const std::vector<Segment> pieces = flip_pieces(m.view(), kFlipper);
  ASSERT_EQ(pieces.size(), 4u);
  int begin = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(pieces[k].begin, begin);
    EXPECT_EQ(pieces[k].end, kFlips[k] + 1);
    begin = kFlips[k] + 1;
  }
  EXPECT_EQ(pieces[3].begin, begin);
  EXPECT_EQ(pieces[3].end, kFrames);
  // A joint that never flips is one piece, even with noise on it.
  test::Motion noisy = m;
  add_noise(GaussianNoise{0.1, 3}, noisy.span());
  ASSERT_EQ(flip_pieces(noisy.view(), 0).size(), 1u);
  EXPECT_EQ(flip_pieces(noisy.view(), 0)[0].end, kFrames);
}

TEST(FlipPieces, EachPieceIsFilteredAndTheFlipsStay) {
  const test::Motion clean = flipping_motion();
  test::Motion noisy = clean;
  add_noise(GaussianNoise{0.03, 9}, noisy.span());
  make_hemisphere_continuous(noisy.span());
  for (const Method method : {Method::bof, Method::gaussian}) {
    const std::string name(to_string(method));
    test::Motion out = noisy;
    const float sentinel = 7.0f;
    for (int t = 0; t < kFrames; ++t)
      for (int j = 0; j < kJoints; ++j)
        if (j != kFlipper) std::fill_n(out.span().at(t, j), 4, sentinel);
    ASSERT_TRUE(filter_flipper(settings_of(method), noisy, out).ok()) << name;

    // Nothing but the flipping joint written.
    for (int t = 0; t < kFrames; ++t)
      for (int j = 0; j < kJoints; ++j) {
        if (j == kFlipper) continue;
        EXPECT_EQ(out.view().at(t, j)[0], sentinel) << name << " " << t << " " << j;
      }
    // The flips where they were, and only there.
    const std::vector<Segment> before = flip_pieces(noisy.view(), kFlipper);
    const std::vector<Segment> after = flip_pieces(out.view(), kFlipper);
    ASSERT_EQ(after.size(), before.size()) << name;
    for (std::size_t k = 0; k < after.size(); ++k)
      EXPECT_EQ(after[k].end, before[k].end) << name << " " << k;
    // Every piece closer to the clean motion than the noise left it (both filters take about
    // half of this noise away), and no sample next to a flip far from it.
    for (const Segment& p : before) {
      const double noisy_rms = piece_rms(noisy, clean, p.begin, p.end);
      const double out_rms = piece_rms(out, clean, p.begin, p.end);
      EXPECT_LT(out_rms, 0.75 * noisy_rms) << name << " piece " << p.begin << "-" << p.end;
    }
    double worst_pieces = 0;
    for (int f : kFlips)
      for (int t = f - 2; t <= f + 3; ++t)
        worst_pieces =
            std::max(worst_pieces, test::rotation_error(out.view(), clean.view(), t, kFlipper));
    EXPECT_LT(worst_pieces, 0.1) << name;
  }
  // The linear filter run across the flips smears each one over its neighbours.
  test::Motion across = noisy;
  MotionIO whole;
  whole.rotations = noisy.view();
  whole.filtered_rotations = across.span();
  whole.joint_begin = kFlipper;
  whole.joint_end = kFlipper + 1;
  ASSERT_TRUE(run_method(settings_of(Method::gaussian), whole, {}).ok());
  double worst_across = 0;
  for (int f : kFlips)
    for (int t = f - 2; t <= f + 3; ++t)
      worst_across =
          std::max(worst_across, test::rotation_error(across.view(), clean.view(), t, kFlipper));
  EXPECT_GT(worst_across, 0.5);
}

// --method auto filters the pieces with its bof for the clip's noise whichever branch the other
// joints took (a Butterworth low-pass of noisy positions rings on short pieces), and leaves them
// as they came on a capture with no noise to take out; a named method filters them itself.
TEST(FlipPieces, AutoFiltersThePiecesWithItsBofAndNothingBelowItsNoiseFloor) {
  constexpr double kFrameTime = 1.0 / 120;
  FilterSettings asked;
  asked.method = Method::automatic;
  for (const bool noisy_positions : {false, true}) {
    const FilterSettings resolved = choose_automatic(asked, 0.03, noisy_positions, kFrameTime);
    ASSERT_EQ(resolved.method, noisy_positions ? Method::butterworth : Method::bof);
    const std::optional<FilterSettings> pieces =
        flip_piece_settings(asked, resolved, 0.03, kFrameTime);
    ASSERT_TRUE(pieces.has_value());
    EXPECT_EQ(pieces->method, Method::bof);
    const BilateralParams got = pieces->param<BilateralParams>();
    const BilateralParams rule = automatic_smoothing(0.03, kFrameTime);
    EXPECT_EQ(got.sigma_g, rule.sigma_g);
    EXPECT_EQ(got.sigma_t, rule.sigma_t);
    EXPECT_EQ(got.iterations, rule.iterations);
  }
  const double clean = 0.5 * kAutoCleanBelow;
  EXPECT_FALSE(flip_piece_settings(asked, choose_automatic(asked, clean), clean, kFrameTime));

  const FilterSettings named = settings_of(Method::gaussian);
  const std::optional<FilterSettings> same = flip_piece_settings(named, named, clean, kFrameTime);
  ASSERT_TRUE(same.has_value());
  EXPECT_EQ(same->method, Method::gaussian);
  EXPECT_EQ(same->param<LinearParams>().sigma_t, 2);

  // What auto's pieces filter does: every piece of a noisy flipping joint closer to the motion.
  const test::Motion clean_motion = flipping_motion();
  test::Motion noisy = clean_motion;
  add_noise(GaussianNoise{0.03, 5}, noisy.span());
  make_hemisphere_continuous(noisy.span());
  test::Motion out = noisy;
  const FilterSettings resolved = choose_automatic(asked, 0.03, true, kFrameTime);
  ASSERT_TRUE(
      filter_flipper(*flip_piece_settings(asked, resolved, 0.03, kFrameTime), noisy, out).ok());
  for (const Segment& p : flip_pieces(noisy.view(), kFlipper))
    EXPECT_LT(piece_rms(out, clean_motion, p.begin, p.end),
              0.75 * piece_rms(noisy, clean_motion, p.begin, p.end))
        << "piece " << p.begin << "-" << p.end;
}

// A flip of another kind than the joint's others (here a half-turn about y where the others turn
// about x, two frames later turned back) cuts a piece that the chart does not join: a piece of
// two frames stays as it came.
TEST(FlipPieces, ShortPiecesBetweenFlipsOfAnotherKindStayAsTheyCame) {
  test::Motion m = flipping_motion();
  const Quat other = exp(Vec3{0, 3.14159265358979 - 0.05, 0});
  const int first = kFlips[0] + 20;
  for (int t = first; t < first + 2; ++t)
    store_quat(m.at(t, kFlipper) * other, m.span().at(t, kFlipper));
  make_hemisphere_continuous(m.span());
  const ChartedPieces charted = charted_flip_pieces(m.view(), kFlipper);
  ASSERT_TRUE(charted.chart.found);
  ASSERT_EQ(charted.pieces.size(), 3u);  // the x flips taken out, cut at the two y flips
  EXPECT_EQ(charted.pieces[1].begin, first);
  ASSERT_EQ(charted.pieces[1].frames(), 2);
  test::Motion out = m;
  ASSERT_TRUE(filter_flipper(settings_of(Method::bof), m, out).ok());
  for (int t = first; t < first + 2; ++t)
    EXPECT_EQ(std::memcmp(out.view().at(t, kFlipper), m.view().at(t, kFlipper), 16), 0) << t;
}

// Flips that are all one rotation (kernels/flip_chart.hpp) join their pieces: a piece of two
// frames between two such flips, which piece by piece had no neighbours, is filtered with the
// frames around it, and its flips stay where they were.
TEST(FlipPieces, ShortPiecesBetweenFlipsOfOneRotationAreFilteredWithTheirNeighbours) {
  const test::Motion clean = flipping_motion();
  test::Motion with_short = clean;
  const Quat flip = exp(Vec3{3.14159265358979 - 0.05, 0, 0});
  const int first = kFlips[0] + 20;  // frames first, first + 1 flipped back: a piece of two
  for (int t = first; t < first + 2; ++t)
    store_quat(with_short.at(t, kFlipper) * inverse(flip), with_short.span().at(t, kFlipper));
  make_hemisphere_continuous(with_short.span());
  ASSERT_EQ(flip_pieces(with_short.view(), kFlipper).size(), 6u);
  const ChartedPieces charted = charted_flip_pieces(with_short.view(), kFlipper);
  ASSERT_TRUE(charted.chart.found);
  EXPECT_FALSE(charted.chart.left);  // the motion turns the flip's axis on the left
  EXPECT_LT(geodesic(charted.chart.flip, flip), 1e-3);
  ASSERT_EQ(charted.pieces.size(), 1u);

  test::Motion noisy = with_short;
  add_noise(GaussianNoise{0.03, 11}, noisy.span());
  make_hemisphere_continuous(noisy.span());
  test::Motion out = noisy;
  ASSERT_TRUE(filter_flipper(settings_of(Method::bof), noisy, out).ok());
  double noisy_error = 0, out_error = 0;
  for (int t = first; t < first + 2; ++t) {
    noisy_error += test::rotation_error(noisy.view(), with_short.view(), t, kFlipper);
    out_error += test::rotation_error(out.view(), with_short.view(), t, kFlipper);
  }
  EXPECT_LT(out_error, 0.75 * noisy_error);
  const std::vector<Segment> before = flip_pieces(noisy.view(), kFlipper);
  const std::vector<Segment> after = flip_pieces(out.view(), kFlipper);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t k = 0; k < after.size(); ++k) EXPECT_EQ(after[k].end, before[k].end) << k;
}

}  // namespace
}  // namespace mocap::engine
