#pragma once
// Foot contacts: the frames where a foot is planted, as ../shared/spec/filters.md ("Metrics",
// foot skating) defines them: near its lowest height and slow. Used by the skating metric (on
// the reference) and by foot locking (on the input before filtering).
//
// Per foot point, from its global track p[t] (Y up, file units):
//   smoothed   = p convolved with a Gaussian of 0.04 s, so measurement noise of the evaluated
//                levels (0.02 rad, 0.4 % of the body) does not read as speed; with
//                noise_speed_fraction > 0 (off by default, docs/feet.md), widened to where the
//                track's own noise n per frame (1.4826 MAD of its horizontal second differences
//                / sqrt 6) reads as a mean speed 1.25 n / (2 pi^(1/4) sigma^1.5 frame_time) of at
//                most that fraction of enter_speed, at most max_smoothing_seconds;
//   floor      = the 5th percentile of the smoothed height over the clip (robust to a few low
//                pops and to clips that start mid-air; the raw heights' sits ~1.6 noise
//                deviations low, which on noisy input fills the whole enter_height band);
//   speed[t]   = |smoothed[t+1] - smoothed[t-1]| / (2 frame_time), horizontal (x, z) only;
//   planted    enters when height - floor < enter_height and speed < enter_speed (raised by the
//              track's noise with noise_allowance > 0), and leaves
//              when height - floor > exit_height or speed > exit_speed (hysteresis: noise near
//              a threshold does not chatter); a break of at most merge_seconds over which the
//              smoothed foot moved less than merge_distance body heights joins the contacts
//              either side; intervals shorter than min_seconds are dropped.
// Thresholds are fractions of the body's height (per second for speeds), so the rule holds in
// any unit and at any frame rate.
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"

namespace mocap {

struct ContactInterval {
  int begin = 0;  // first planted frame
  int end = 0;    // one past the last
  int frames() const { return end - begin; }
  bool operator==(const ContactInterval&) const = default;
};

struct FootContactParams {
  double enter_height = 0.03;  // of body height above the foot's floor
  double exit_height = 0.045;
  double enter_speed = 0.25;  // body heights per second, horizontal
  double exit_speed = 0.40;
  double smoothing_seconds = 0.04;
  double max_smoothing_seconds = 0.25;
  // Of enter_speed: what the track's noise may read as (0: a width of smoothing_seconds only;
  // docs/feet.md: widening the smoothing by the noise joined the swings of the demo's noisier
  // clips (0.05 rad) to their stances, and cost them 5-11 dB of rotation PSNR).
  double noise_speed_fraction = 0;
  // a: how many times the track's own noise speed e (the rms speed that its noise n, as above,
  // reads as after the smoothing) the enter threshold allows for, in quadrature:
  // enter_speed' = sqrt(enter_speed^2 + (a e)^2), exit_speed' = max(exit_speed, enter_speed').
  // With noise a planted foot reads as moving by the noise alone. 0: the thresholds as given
  // (the skating metric's contacts); the lock's detector uses engine's kContactNoiseAllowance.
  double noise_allowance = 0;
  double merge_seconds = 0.1;
  double merge_distance = 0.01;  // of body height
  double min_seconds = 0.05;

  Status validate() const;
};

// The squared central-difference speed per frame^2, (s[t+1] - s[t-1])^2 / 4 summed over the two
// horizontal axes, that white noise of unit variance per axis has after the detector's Gaussian
// smoothing of sigma frames (taps g, normalized; none below 0.5 frames):
// 2 sum_r ((g(r+1) - g(r-1)) / 2)^2, within 2 % of 1 / (2 sqrt(pi) sigma^3) from 4.8 frames
// (the central difference differentiates less than the derivative at narrower widths).
double smoothed_speed_gain(double sigma);

struct FootContactJob {
  FootContactParams params;
  TranslationView feet;  // [F][N][3] global positions of N foot points, Y up
  double frame_time = 0;
  double body_height = 0;                                         // file units, > 0
  std::vector<std::vector<ContactInterval>>* contacts = nullptr;  // written: one list per foot

  Status validate() const;
  Status run() const;
};

// The contacts found on a clip as it came, each widened over the frames where the same foot is
// also planted in its filtered motion and stays put there (docs/feet.md, "Widening"). Noise
// breaks a contact of the input into fragments and clips its ends (the detector's thresholds
// read the noise as speed); the filtered motion, whose noise is gone, still holds the foot
// planted across them. Per input contact k, pin p_k = the per-axis median (x, z) of the filtered
// track over it; it grows frame by frame, forward from its end and backward from its begin,
// while the frame lies in a contact of `filtered` and the filtered foot stays within `reach`
// (horizontal distance, file units) of p_k, never into another input contact; where it reaches
// the next input contact and that contact's pin lies within `reach` of p_k, the two are one.
// Only grows what the input found: a contact of the filtered motion alone is not added, and a
// foot that steps (moves more than `reach`) ends its contact there, so successive low steps
// stay apart.
std::vector<ContactInterval> widen_contacts(const std::vector<ContactInterval>& input,
                                            const std::vector<ContactInterval>& filtered,
                                            std::span<const Vec3> track, double reach);

// A leg by joint index (-1 = none): ankle is the foot point, knee its parent, hip the knee's
// parent; toe is a child of the ankle when there is one.
struct FootChain {
  int hip = -1, knee = -1, ankle = -1, toe = -1;
  char side = '?';  // 'L', 'R' or '?'
};

// The feet of a skeleton. By name first: per side (Left/Right, L/R prefix), the shallowest joint
// whose name contains "foot" or "ankle" (else "toe"). Without such names: the two leaves lowest in
// the rest pose (offsets only), each taken as the ankle. No two legs share a hip, knee or ankle
// (a leg that would is left out). Chains shallower than three joints keep
// -1 for what is missing. Parents precede children.
std::vector<FootChain> find_feet(std::span<const std::string> names, std::span<const int> parents,
                                 std::span<const Vec3> offsets);

// The skeleton's height in its rest pose (all rotations identity): the vertical extent of its
// joints and of the given end-site points (joint, offset), in file units.
double rest_height(std::span<const int> parents, std::span<const Vec3> offsets,
                   std::span<const std::pair<int, Vec3>> end_sites);

// True at frames inside one of the intervals.
std::vector<std::uint8_t> contact_mask(const std::vector<ContactInterval>& intervals, int frames);

}  // namespace mocap
