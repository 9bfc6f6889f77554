#pragma once
// Foot locking: after a filter, pins each planted foot to one position per contact with analytic
// two-bone IK on its leg, so that smoothing the joints one by one no longer makes the feet slide
// (not part of the spec's filters; docs/feet.md).
//
// Per leg (hip -> knee -> ankle, optional toe below the ankle), Y up:
//   Contacts. The frames where the ankle's contact list (kernels/foot_contacts.hpp, found on the
//   input) holds the ankle, else the frames where the toe's list (if given) holds the toe; a run of
//   adjacent such frames is one contact. Its pin, over its ankle frames (its toe frames when it
//   has none): with input_anchors, that point of the input (the motion the contacts were found
//   on) smoothed by a Gaussian of sigma_p frames within those frames (weights renormalized at
//   their ends), so the foot keeps the capture's own motion during the contact and loses the
//   filter's slide and the input's noise; sigma_p = pin_width x the anchors' noise (in body
//   heights: 1.4826 MAD of the second differences of x and z over the frames inside contacts,
//   / sqrt(6) for white noise), within [min_pin_sigma, max_pin_sigma]. Without input_anchors,
//   one pin per contact: the per-axis median (x, z) of that point in the filtered motion.
//   A toe frame of a contact with ankle frames takes the offset the ankle had at the frame next
//   to it, so the target does not jump where the heel lifts or lands.
//   Target. The ankle's target is its filtered position plus an offset D(t): pin - anchor(t)
//   inside a contact (anchor: the ankle, or the toe for a toe frame, then D moves the ankle so that
//   the toe sits on its pin with the filtered foot orientation); between two contacts closer than
//   2 B frames, D goes linearly from one to the other; otherwise it fades in over the B frames
//   before a contact and out over the B frames after it with a smoothstep s(x) = x^2 (3 - 2x)
//   (B = blend_time / frame_time, at least 1). D = 0 elsewhere, where nothing is touched.
//   Only D's horizontal part (x, z) is applied: sliding is horizontal, and a pin's height would
//   change the leg's length, which near a straight knee turns the knee fast (the knee angle per
//   unit of length grows as 1 / sin of the knee angle). Measured on the shared clips: pinning
//   all three axes made the peak knee speed up to 3.3x the input's, horizontal only 1.5x.
//   Lift. Even the horizontal offset changes the hip-target distance where the leg leans, and the
//   knee then takes up the change, amplified near straight: the knee carried most of what the
//   lock cost the rotations. So the target's height may move by v within [-lift m, lift m] (m
//   the input anchors' noise, "Reach"; lift = params.lift, 0 without input_anchors): v puts the
//   target as far from the hip as the filtered ankle, on the ankle's side of the hip,
//   v = +-sqrt(|c - a|^2 - h^2) - (T - a)_y with h the target's horizontal distance from the
//   hip (v = 0 where h >= |c - a|), clamped. The hip alone then swings the ankle onto the pin
//   wherever the needed height lies within the capture's own noise; the ankle's height departs
//   from the filtered one by at most lift m.
//   IK (Holden's analytic two-joint IK). Hip a, knee b, ankle c, target T, thigh l1 = |b - a|,
//   shin l2 = |c - b|, d = |T - a| clamped to [|l1 - l2|, L], L = max(max_reach (l1 + l2),
//   |c - a|) capped at l1 + l2. The knee turns about the filtered bend-plane normal
//   n = (b - a) x (c - a) / |.| (the last frame's when the leg is straight) from its interior
//   angle theta0 = angle(a - b, c - b) to theta1 = acos((l1^2 + l2^2 - d^2) / (2 l1 l2)):
//   Q_k = Exp((theta0 - theta1) n); then the hip swings the new ankle onto T by the shortest arc
//   Q_h. Global rotations: R_hip' = Q_h R_hip, R_knee' = Q_h Q_k R_knee, R_ankle' = R_ankle (the
//   foot's global orientation is kept, so the toe's too), stored as local rotations of hip, knee
//   and ankle, each on the hemisphere of the rotation it replaces.
//   Bend side. A knee the filter leaves near straight may bend a hair backwards (noise, or a
//   capture that holds the knee straight): n then points the other way, the IK bends the knee
//   backwards, and where the noise flips n (or turns it sideways) from frame to frame the knee
//   chatters about it (docs/feet.md, "Bend side"). The side is the clip's own: its hinge h_ref
//   is the bend-plane normal in the thigh's frame, h(t) = o_k x (q_k(t) o_a) (the knee's and
//   the ankle's offsets, the knee's local rotation), at the frame where the knee bends most (of
//   every 4th frame; at least kBendSideMinBend, else none and the rule above holds). A frame
//   with h(t) . h_ref < 0 counts as straight: n turned to the clip's side, theta0 = pi (the
//   knee then ends at theta1 plus its small backward bend), theta_f = pi for the knee's limit.
//   Below kBendSideMinBend of filtered bend b, the turn's axis is the normalized blend s n +
//   (1 - s) h_ref' (s = smoothstep(b / kBendSideMinBend); h_ref' the hinge through the hip's
//   global rotation, made perpendicular to the shin): a noisy plane gives way to the hinge.
//   Reach. Where |T - a| > L for a planted leg, the root (the leg's top ancestor, when it carries
//   a translation) is lowered along Y just enough for the hip to reach: a_y' = T_y +
//   sqrt(L^2 - h^2), h the horizontal hip-target distance; by the largest drop of its legs.
//   Over each run of consecutive touched frames a root's drops d become max(d - m, G * d), G a
//   Gaussian (sigma w / 2, w = drop_time / frame_time) truncated at +-w, the frames outside the
//   run taken as 0, the run's two end frames kept; m the input anchors' noise (stats'
//   anchor_noise times body_height; 0 without input_anchors). Where noise makes the need come
//   and go from frame to frame the root no longer steps down and back up with it (which bent
//   the knee to and fro: docs/feet.md, "Reach"). No frame is lowered deeper than the deepest
//   need within w frames, nor less than its own need minus m: where G * d < d the IK clamps at
//   max_reach and the ankle stops short of its pin by at most m, the capture's own noise there
//   (max(d, G * d), m = 0, held it exactly but lowered the root through the need's dips and
//   measured worse).
//   Knee speed. Near a straight leg the knee angle per unit of hip-target distance grows as
//   1 / sin(theta), so a pin the filtered ankle moves away from (at a contact's end the filtered
//   ankle already leaves: the filter spreads the lift-off in time) asks the knee to catch up
//   with the filter in a frame or two: a pop (measured: up to 1.7x the input's peak knee speed).
//   So the change the IK makes to the knee's interior angle, Delta(t) = theta_1(t) -
//   theta_f(t), is kept such that the locked knee turns no faster than a limit W (the filtered
//   motion's own peak knee speed by default, peak_knee_speed): the filter's knee turn s_f(t)
//   per frame splits into its interior-angle part g(t) and a twist r (r^2 = s_f^2 - g^2) the IK
//   keeps, and the IK adds Delta(t) - Delta(t-1) to the interior part, so |g + Delta(t) -
//   Delta(t-1)| <= sqrt((W frame_time)^2 - r^2); Delta must be back to 0 on the frame after each
//   run of IK frames (a backward pass gives the band of Delta that can still get there; the
//   forward pass clamps the wanted Delta into it and into the step from the previous frame's).
//   A bound on the interior angle alone let the filter's twist add to it (eval: 1.22x). Where
//   the limit bites the ankle misses its target along the hip-target line by what the knee could
//   not do.
// Frames with D = 0 on every leg of a root and no drop within w frames are left bit-identical,
// and so is every joint that is not a hip, knee or ankle of a leg (rotations) or a lowered root
// (translation).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/implementation.hpp"

namespace mocap {

// Header, "Bend side": the least bend (rad) of a clip's knee that tells which side it bends to.
inline constexpr double kBendSideMinBend = 0.2;

struct FootLockParams {
  double blend_time = 0.1;   // seconds of fade in before and fade out after each contact
  double max_reach = 0.995;  // fraction of the straight leg the IK may stretch to
  double drop_time = 0.05;   // seconds: the half-width w of the roots' drops' envelope ("Reach")
  // The knee's speed limit, rad/s (header, "Knee speed"): 0, the filtered motion's own peak
  // knee speed (peak_knee_speed over all steps); < 0, no limit.
  double max_knee_speed = 0;
  // With input_anchors, the pins' Gaussian width (header, "Contacts"): pin_width frames per body
  // height of the anchors' noise, within [min_pin_sigma, max_pin_sigma] seconds (docs/feet.md,
  // "Pin", says how they were chosen).
  double pin_width = 700;
  double min_pin_sigma = 0.02;
  double max_pin_sigma = 1.0;
  // With input_anchors, the ankle's target may rise or sink by up to lift x the anchors' noise
  // where that keeps the leg's length (header, "Lift"); 0: the filtered height, exactly.
  double lift = 1.0;

  Status validate() const;
};

// The largest angular speed (rad/s) of the legs' knee rotations over the steps t-1 -> t of
// `rotations` with counted[t] (empty: all steps), each step's speed capped by the larger of its
// neighbouring steps' (a lone one-step spike, such as a glued T-pose frame, is not motion).
double peak_knee_speed(RotationView rotations, std::span<const FootChain> legs, double frame_time,
                       std::span<const std::uint8_t> counted = {});

struct FootLockStats {
  int contacts = 0;         // contacts locked, over all legs
  int locked_frames = 0;    // leg-frames inside a contact
  int lowered_frames = 0;   // frames where a root was lowered
  double max_drop = 0;      // the largest drop of a root (file units)
  double anchor_noise = 0;  // with input_anchors: their noise, body heights
  double pin_sigma = 0;     // with input_anchors: the pins' Gaussian width, seconds
};

// The working memory of FootLockJob::run (ozz-animation's scratch buffer): the fast path's planes
// of one chunk of touched frames and every per-frame and per-leg vector. Owned by the caller and
// reused across runs (clips): once it has grown to the longest clip, a run allocates nothing and
// touches no fresh page (docs/feet.md, cost: fresh memory was most of the lock's time in the
// pipeline). What it holds between runs means nothing to the next (results do not depend on it);
// it serves one run at a time (one per thread). The scalar reference allocates its own planes.
struct FootLockScratch {
  std::unique_ptr<double[]> planes;  // the fast path's planes of one chunk of frames, one block
  std::size_t plane_capacity = 0;    // doubles in `planes`
  std::vector<FootChain> chains;     // the complete legs, and their contact lists
  std::vector<const std::vector<ContactInterval>*> ankle_lists, toe_lists;
  // [leg][frame] (flat): contact labels, D(t), locked or blending, bent backwards (header, "Bend
  // side"), the knee's |q(t-1) . q(t)| ([leg][frame + 1]).
  std::vector<std::uint8_t> labels, active, hyperextended;
  std::vector<Vec3> offsets;
  std::vector<double> knee_cos;
  // Per frame, or per touched frame (plane index); ik: [leg][frame] in the fast path.
  std::vector<std::uint8_t> touched, ik, solve, marks;
  std::vector<int> frame_of, index_of, slot, needed, roots;
  std::vector<double> low, high, gain, room;  // [leg][frame] in the fast path
  // Per leg and touched frame (fast path): the anchors ([leg][ankle, toe][i]), the knee's
  // interior angle, the roots' drops (rows padded), the knee's turn (one leg at a time).
  std::vector<Vec3> anchors;
  std::vector<double> theta_f, leg_drops, turn;
  // Per leg: the bend-plane normal carried over straight frames, the knee's hinge in the thigh's
  // frame (header, "Bend side"), the hip's rotation at frame 0,
  // the knee limit's Delta(t - 1).
  std::vector<Vec3> first_normals, hinges;
  std::vector<Quat> hip_rotations;
  std::vector<double> deltas;
  // One contact's anchor positions and their x, z (the pins' medians).
  std::vector<Vec3> points;
  std::vector<double> xs, zs;
  std::vector<int> leg_of;                     // per complete leg, its index in FootLockJob::legs
  std::vector<double> pin_weights;             // the pins' Gaussian, w[|j - k|]; empty: median pins
  std::vector<double> drop_weights, envelope;  // the drops' envelope (header, "Reach")
  double drop_total = 0;      // the envelope's weights summed over all 2w + 1 frames
  double drop_allowance = 0;  // m, file units (header, "Reach")
  double lift = 0;            // the targets' largest lift, file units (header, "Lift")
  struct Segment {            // a run of frames with the same anchor (1: ankle, 2: toe)
    int begin, end, anchor;
  };
  struct Cluster {  // a contact: a run of adjacent segments, indices inclusive
    int first, last;
  };
  std::vector<Segment> segments;
  std::vector<Cluster> clusters;
  std::vector<std::pair<int, double>> drops;  // (root, drop) at one frame
};

struct FootLockJob {
  FootLockParams params;
  // Skeleton (forward_kinematics.hpp's conventions): parents precede children.
  std::span<const int> parents;
  std::span<const Vec3> offsets;
  std::span<const std::uint8_t> translated_joints;  // empty, or one entry per joint
  double frame_time = 1.0 / 120.0;
  // The filtered motion, read and edited in place.
  RotationSpan rotations;
  TranslationSpan translations;  // [F][J][3]; needed when translated_joints is given
  // Legs (kernels/foot_contacts.hpp's find_feet); a leg without hip, knee or ankle is skipped.
  std::span<const FootChain> legs;
  // One list per leg: the ankle's contacts; optionally one list per leg for the toe's (empty:
  // none), which lock the foot where only the toe is planted.
  std::span<const std::vector<ContactInterval>> contacts;
  std::span<const std::vector<ContactInterval>> toe_contacts;
  // Optional, one entry per frame: 0 where the step t-1 -> t is not motion (into or out of a
  // one-frame segment such as CMU's T-pose frame 0): left out of the knee's peak speed, and the
  // knee's speed limit does not hold across it.
  std::span<const std::uint8_t> counted_steps;
  // Optional, [F][legs][2][3]: the ankle's and the toe's positions per leg (the ankle's twice for
  // a leg without toe) in the motion the contacts were found on (the unfiltered input): the pins
  // follow them (header, "Contacts"). Empty: one median pin per contact.
  std::span<const float> input_anchors;
  double body_height = 0;  // file units; > 0 with input_anchors
  // input_anchors' point `which` (0: ankle, 1: toe) of leg `leg` at frame t.
  Vec3 input_anchor(std::size_t leg, int which, std::size_t t) const {
    const float* p = input_anchors.data() + ((t * legs.size() + leg) * 2 + std::size_t(which)) * 3;
    return {p[0], p[1], p[2]};
  }
  FootLockStats* stats = nullptr;  // optional, written
  // Optional working memory kept across runs (nullptr: the run allocates its own).
  FootLockScratch* scratch = nullptr;
  // reference: the scalar path, frame by frame, as the equations above. fast: the same steps
  // with the touched frames as planes through kernels/simd/foot_lock_simd.hpp; only the rounding
  // differs (tests/kernels/foot_lock_test.cpp compares them).
  Implementation implementation = Implementation::fast;

  // Sizes agree, legs are hip -> knee -> ankle (-> toe) chains, no joint in two legs, one
  // contact list per leg, intervals ordered and disjoint within one list.
  Status validate() const;
  Status run() const;
};

}  // namespace mocap
