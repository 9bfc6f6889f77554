#pragma once
// Forward kinematics of a joint hierarchy (BVH semantics): the global position of every joint and
// of extra points fixed to a joint (End Sites) from the local rotations and translations.
//
//     R[j] = R[parent] q[t][j],           p[j] = p[parent] + R[parent] (local translation of j)
//     root: R = q[t][root],               p = its local translation
//     site s of joint j:                  p = p[j] + R[j] offset_s
//
// A joint's local translation is its offset, or, for the joints marked in translated_joints, the
// per-frame translation (BVH position channels: the root of CMU files). Plain arrays in; no
// skeleton type, so that kernels/ stays free of io/.
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"
#include "kernels/implementation.hpp"

namespace mocap {

// A point rigidly attached to a joint (an End Site, or any marker).
struct JointSite {
  int joint = 0;
  Vec3 offset;  // in the joint's frame
};

struct ForwardKinematicsJob {
  std::span<const int> parents;   // [J]; -1 = a root; every parent precedes its children
  std::span<const Vec3> offsets;  // [J]: a joint's position in its parent's frame
  RotationView rotations;         // [F][J][4] local rotations, wxyz
  // Optional [F][J][3], used for the joints with translated_joints[j] != 0 (then one entry per
  // joint), whose per-frame translation replaces the offset.
  TranslationView translations;
  std::span<const std::uint8_t> translated_joints;
  std::span<const JointSite> sites;
  // Optional: only these joints' positions are wanted, and then `positions` is [F][K][3] in this
  // order (K = its size) and only the joints on their chains to the root are computed, with the
  // same arithmetic: what a caller needs of a few joints (the ankles) costs their chains, not
  // the whole skeleton. Empty: every joint, [F][J][3]. Sites need the whole skeleton.
  std::span<const int> output_joints;
  TranslationSpan positions;       // [F][J][3] (or [F][K][3]), written: global joint positions
  TranslationSpan site_positions;  // [F][S][3], written (may be empty when there are no sites)
  // reference: the scalar path, frame by frame, joint by joint. fast: the same operations with
  // chunks of frames as vector lanes (kernels/simd/forward_kinematics_simd.hpp); bit-identical.
  Implementation implementation = Implementation::fast;

  // Sizes agree, parents precede their children, sites name existing joints, the implementation
  // is known.
  Status validate() const;
  Status run() const;
};

}  // namespace mocap
