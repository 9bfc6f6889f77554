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
// limb in motion, three joints or more, does not look like. coherence, reach and pop_group were
// calibrated with `eval --pop-stage repair` at 30 and 24 fps on ../shared/data/bvh, together with
// the detour test (kernels/pop_detour.hpp) whose flags this test also reads (docs/pops.md:
// the grids and what each choice cost).
//
// Strong detours. A neighbour's quadratic also misses for reasons of its own: at a segment's
// first frames its fit extrapolates, and a fast limb there leaves it 0.3-0.5 rad off, enough to
// veto a pop of 0.9 rad beside it. Where the flagged sample's own detour
// E_j(t) (kernels/pop_detour.hpp) exceeds strong_detour, far above what real motion makes at
// 30 fps, a neighbour counts as moving with it only if it also turns back at that frame:
// E_k(u) >= coherence * E_j(t) as well (a limb that reverses in one frame does; a neighbour
// whose fit merely misses does not). Samples at a clip's first or last frame have no detour and
// keep the residual test alone. Under heavy noise every sample detours, a pop no more than the
// noise (0.24 rad of it per axis gives detours past 2 rad, a pop's most), so the bar is at least
// kStrongDetourOverMedian x the joint's median detour: twice the detour test's own floor, and
// above 1 rad from about 0.06 rad of noise up.
#include <cstdint>
#include <span>

#include "core/status.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap {

inline constexpr double kPopCoherence = 0.5;
inline constexpr int kPopCoherenceReach = 0;
inline constexpr int kPopGroup = 2;
inline constexpr double kPopStrongDetour = 1.0;  // rad, header "Strong detours"
inline constexpr double kStrongDetourOverMedian = 8.0;

struct PopSkeletonJob {
  PopRepairParams params;  // of the per-joint test that flagged the samples (for the residuals)
  double coherence = kPopCoherence;
  int reach = kPopCoherenceReach;  // frames either side of t where a neighbour's residual counts
  // Flagged neighbours do not count within a group of at most this many flagged joints (0: they
  // always count; the joint count: never).
  int pop_group = kPopGroup;
  double strong_detour = 0;  // rad, header "Strong detours"; 0: the residual test alone
  // Optional, one per joint: each joint's median detour on these very rotations, as
  // PopDetourJob::median_detours gives it (NaN: not given); without it the test measures the
  // joints it needs (the same bits).
  std::span<const double> median_detours;
  RotationView rotations;              // [F][J], the clip (segment) the flags belong to
  std::span<const int> parents;        // one per joint, -1 for a root
  std::span<const std::uint8_t> skip;  // optional, one per joint: garbage, not a neighbour
  std::span<std::uint8_t> flags;       // [F][J]: in, find_pops' flags; out, the pops left

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
