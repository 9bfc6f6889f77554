#pragma once
// The skeleton's word on pop flags (issue 13): find_pops (kernels/pop_repair.hpp) looks at one
// joint's curve in time, and at 30 fps a quadratic over +-5 frames no longer follows a fast limb
// (knees and feet at a step, a hand at a throw): it flags about 0.17 % of clean samples. A pop (the
// spec's `impulse` model, ../shared/spec/filters.md "Noise models": q := q Exp(n) on one joint)
// moves one joint's local rotation alone; real fast motion moves a limb, so the joint's parent
// or a child leaves its own quadratic at the same frame too.
//
// Test, per flagged sample (t, j): let r_k(t) be pop_residuals' residual of joint k at t (rad,
// its distance from the quadratic its clean neighbours predict). The flag stays when every
// skeleton neighbour k of j (its parent and its children, garbage joints left out) that is not
// flagged itself at t has r_k(t) < coherence * r_j(t); else the sample is taken for coherent
// motion and unflagged. A neighbour flagged at the same frame is left out of the test: two pops
// on neighbouring joints in one frame (about 1 in 30 pops at the spec's rate 0.01) are not
// motion.
//
// Measured (a numpy model of the test on the 9 CMU clips of ../shared/data/bvh at every 4th
// frame, the spec's pops at rate 0.01, README "Pops and garbage joints"): with coherence 0.3
// the clean samples flagged fell from 0.135 % to 0.071 % and the pops found from 617 to 615 of
// 631.
#include <cstdint>
#include <span>

#include "kernels/motion_io.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/status.hpp"

namespace mocap {

inline constexpr double kPopCoherence = 0.3;
inline constexpr int kPopCoherenceReach = 0;
inline constexpr bool kPopFlaggedNeighboursCount = true;

struct PopSkeletonJob {
  PopRepairParams params;  // of the per-joint test that flagged the samples (for the residuals)
  double coherence = kPopCoherence;
  int reach = kPopCoherenceReach;  // frames either side of t where a neighbour's residual counts
  bool flagged_neighbours_count = kPopFlaggedNeighboursCount;
  RotationView rotations;              // [F][J], the clip (segment) the flags belong to
  std::span<const int> parents;        // one per joint, -1 for a root
  std::span<const std::uint8_t> skip;  // optional, one per joint: garbage, not a neighbour
  std::span<std::uint8_t> flags;       // [F][J]: in, find_pops' flags; out, the pops left
  int* unflagged = nullptr;            // optional out: how many flags the skeleton removed

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
