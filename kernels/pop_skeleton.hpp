#pragma once
// The skeleton's word on pop flags (issue 13): find_pops (kernels/pop_repair.hpp) looks at one
// joint's curve in time, and at 30 fps a quadratic over +-5 frames no longer follows a fast limb
// (knees and feet at a step, a hand at a throw): it flags about 0.28 % of clean samples. A pop (the
// spec's `impulse` model, ../shared/spec/filters.md "Noise models": q := q Exp(n) on one joint)
// moves one joint's local rotation alone; real fast motion moves a limb, so the joint's parent
// or a child leaves its own quadratic at the same frame too.
//
// Test, per flagged sample (t, j): let r_k(u) be pop_residuals' residual of joint k at frame u
// (rad, its distance from the quadratic its clean neighbours predict). The flag stays when every
// skeleton neighbour k of j (its parent and its children, garbage joints left out) has
// r_k(u) < coherence * r_j(t) at every u within `reach` frames of t; else the sample is taken for
// coherent motion and unflagged. A neighbour flagged itself counts too (a whole limb that leaves
// its quadratic at one frame, a fast kick at 30 fps, is motion), except where the joints flagged
// at its frame that it reaches through flagged neighbours number at most pop_group: two joints
// popped side by side in the same frame, which the spec's pops make (rate 0.01 per sample) and a
// limb in motion, three joints or more, does not look like. Measured with `eval --pop-stage
// repair` on the 9 shared clips with the low-rate parameters (engine/clip/clip_conditioning.hpp,
// pop_params_at): of the 27 pops left at 30 fps when every flagged neighbour counted, 16 were two
// neighbouring joints popped in the same frame; with groups of 2 kept, 97.8 % of the popped samples
// removed instead of 96.4 % (pooled 47.81 -> 50.20 dB), clean flags the same 9 (0.011 %); at 24 fps
// 94.3 % -> 95.6 % (46.75 -> 48.08 dB), clean flags 15 -> 17. Groups of 3 or more never formed on
// the shared clips (any limit from 2 up gave the same flags); a limb swinging in one frame does
// (tests/engine/clip/pop_skeleton_test.cpp).
//
// Measured with `eval --frame-step 4` on the 9 CMU clips of ../shared/data/bvh (README "Pops and
// garbage joints"): clean samples flagged 221 (0.277 %) by the per-joint test alone, 68 (0.085 %)
// with this test; of the 835 samples the spec's pops (rate 0.01) moved, 808 still flagged.
// reach 0 and flagged neighbours counting were chosen on a numpy model of the test with the
// default parameters (clean flags 0.045 % and pops kept 96.4 % there, against 0.071 % and 97.5 %
// when flagged neighbours do not count and 0.039 % and 91.1 % with a reach of one frame).
#include <cstdint>
#include <span>

#include "core/status.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap {

inline constexpr double kPopCoherence = 0.3;
inline constexpr int kPopCoherenceReach = 0;
inline constexpr int kPopGroup = 2;

struct PopSkeletonJob {
  PopRepairParams params;  // of the per-joint test that flagged the samples (for the residuals)
  double coherence = kPopCoherence;
  int reach = kPopCoherenceReach;  // frames either side of t where a neighbour's residual counts
  // Flagged neighbours do not count within a group of at most this many flagged joints (0: they
  // always count; the joint count: never).
  int pop_group = kPopGroup;
  RotationView rotations;              // [F][J], the clip (segment) the flags belong to
  std::span<const int> parents;        // one per joint, -1 for a root
  std::span<const std::uint8_t> skip;  // optional, one per joint: garbage, not a neighbour
  std::span<std::uint8_t> flags;       // [F][J]: in, find_pops' flags; out, the pops left
  int* unflagged = nullptr;            // optional out: how many flags the skeleton removed

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
