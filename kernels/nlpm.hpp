#pragma once
// Non-local pose means, ../shared/spec/filters.md, "Non-local pose means (nlpm, Dean & Lewis
// 2017)": each pose is replaced by a weighted mean of the poses in its search window, weighted by
// how alike their surrounding patches of poses are.
//
//     D(t, s)   = (1/(2P+1)) sum_{o=-P}^{P} e(t+o, s+o)                  (e: pose_distance.hpp)
//     f(t, s)   = exp(-(D(t, s) - D_min(t)) / (2 h^2)),  s != t,  s in [t-K, t+K] ∩ [0, F)
//     f(t, t)   = max_{s != t} f(t, s)   (= 1)
//     q'[t][j]  = q[t][j] Exp( sum_s f(t,s) Log(q[t][j]^-1 q[s][j]) / sum_s f(t,s) )   all joints
//
// Option range_sigma > 0, the robust (non-local bilateral) form, which neither paper has: each
// joint's weights also carry a range term in that joint's own geodesic distance (spec
// "Conventions"), so a sample of one joint that disagrees with q[t][j] (a pi flip of an uncaptured
// thumb, a pop) is left out of that joint's mean instead of being averaged in:
//
//     w_j(t, s) = f(t,s) exp(-d(q[t][j], q[s][j])^2 / (2 range_sigma^2)),  w_j(t, t) = f(t, t)
//     q'[t][j]  = q[t][j] Exp( sum_s w_j(t,s) Log(q[t][j]^-1 q[s][j]) / sum_s w_j(t,s) )
//
// range_sigma = 0 stays the default: on clean synthetic motion with clean f the term trades
// variance for bias and loses (tests/kernels/nlpm_test.cpp, NlpmRange.* print the measurements).
//
// Translations (spec "Translations"; its first version's pose-weighted mean of p[s] is withdrawn):
// a Gaussian of translation_sigma_t frames along time, the same for every frame,
//
//     p'[t][j]  = sum_{r=-k}^{k} exp(-r^2 / (2 s^2)) p[t+r][j] / sum_r exp(-r^2 / (2 s^2)),
//                 s = translation_sigma_t, k = ceil(3 s), boundary-extended like the rotations,
//
// because pose similarity says nothing about where in space a pose is: f(t, s) is not symmetric in
// s - t, so its mean of p[s] drags the root toward the frames that look alike (a 2.6 cm sawtooth on
// a 30 fps walk). Symmetric, normalised weights reproduce p = a + v t exactly away from the ends,
// and a Gaussian's gain is at most 1 at every frequency, so it does not raise the jitter (RMS
// second difference) of a clean capture. The engine derives s from the estimated translation noise
// (engine's automatic rules); 0 leaves translations as they are.
//
// This is the fast form of the spec: the band E[u][delta] = e(u, u + delta) is evaluated once per
// (u, |delta|), and D(t, t + delta) is a running box sum of E[.][delta] along t. nlpm_direct.hpp
// holds the literal double sum, the test oracle.
#include <cstdint>
#include <span>
#include <vector>

#include "core/status.hpp"
#include "kernels/boundary.hpp"
#include "kernels/implementation.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/pose_distance.hpp"

namespace mocap {

struct NlpmParams {
  int search_radius = 10;  // K: window of 2K+1 poses (the paper's 21)
  int patch_radius = 5;    // P: patch of 2P+1 poses (the paper's 11)
  double h = 0;            // rad; 0 = not given: the caller derives it (engine). run() needs h > 0
  NlpmSpace space = NlpmSpace::tangent;
  Boundary boundary = Boundary::mirror;
  // rad; 0 = off: exactly the spec's nlpm (bit for bit as without the option). > 0: the range
  // term above with sigma_g = range_sigma (tangent space only; the log space is the paper's).
  double range_sigma = 0;
  // rad; 0 = off (the spec's e). > 0: each joint's term of e(u, v) is capped,
  // min(d^2, distance_cap^2), so one joint far from its pose (a glitch of the capture, a pop the
  // pop stage missed) cannot make a whole patch unlike its neighbours' (tangent space only).
  double distance_cap = 0;
  // frames; the Gaussian of the translated joints (above); 0 = translations unchanged.
  double translation_sigma_t = 1.0;
  int translation_reach() const;  // ceil(3 translation_sigma_t)

  // K >= 1, P >= 0 (both at most kNlpmMaxRadius), h >= 0 and finite (0 = still to be derived),
  // range_sigma and distance_cap >= 0 and finite, and > 0 only with space tangent;
  // translation_sigma_t >= 0, finite and at most kNlpmMaxRadius.
  Status validate() const;
};

// Radii beyond this are certainly mistakes (the paper uses K = 10, P = 5); the bound keeps the
// working memory, about (1024 + 2P + K) (K + 1) doubles plus (1024 + 2P + 2K) J_d quaternions, in
// the tens of megabytes.
inline constexpr int kNlpmMaxRadius = 1000;

// The running sums of D restart at every multiple of this many frames (counted from frame 0 of
// the clip), so D(t, s) does not depend on where the output slice begins: the engine's time
// blocks then reproduce the full run bit for bit.
inline constexpr int kNlpmAnchorFrames = 64;

struct NlpmJob {
  NlpmParams params;
  MotionIO io;
  // Empty = all joints count in e(u, v); else one entry per joint, nonzero = a distance joint.
  // Every joint is filtered either way; the mask only chooses what the weights look at.
  std::span<const std::uint8_t> distance_joints;
  // fast: kernels/simd/nlpm_simd.hpp (float32 band and averaging, double weights) for the tangent
  // space, range form included (float32 range terms); the log space (comparison only) always
  // runs the reference below.
  Implementation implementation = Implementation::fast;

  // params.validate(), h > 0, io.validate(), the mask's size and that it marks a joint.
  Status validate() const;
  // Writes io's output slice. Reads the whole input: weights come from all distance joints and
  // from frames outside the slice, so any slice reproduces the full run's samples bit for bit.
  // A clip of one frame is copied unchanged (no s != t to average with).
  Status run() const;
};

// The patch distances D(t, t + delta) exactly as NlpmJob::run() computes them (bit for bit), for
// t in [frame_begin, frame_end) and |delta| <= K' = min(K, F - 1):
// out[(t - frame_begin) * (2K' + 1) + delta + K']. Entries with t + delta outside [0, F) are
// computed (from extended frames) but run() does not use them. h is not needed here. For tests
// of the determinism contract and for diagnostics.
Status nlpm_patch_distances(const NlpmParams& params, RotationView rotations,
                            std::span<const std::uint8_t> distance_joints, int frame_begin,
                            int frame_end, std::vector<double>& out);

// The joints the mask marks (all joints for an empty mask), in ascending order.
std::vector<int> nlpm_distance_joints(std::span<const std::uint8_t> mask, int joints);

}  // namespace mocap
