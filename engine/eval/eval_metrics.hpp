#pragma once
// eval's scores of a filtered clip against its clean original, over the frames of the segments
// that were filtered (segments of at least 2 frames; see kernels/motion_split.hpp):
//   - rotations: geodesic RMSE and PSNR (spec "Metrics"), pooled over joints and frames;
//   - end effectors: RMS distance (cm) of the hands and feet through forward kinematics;
//   - foot skating: the share of a foot's frame-to-frame steps in which it moves more than
//     2.5 cm horizontally while within 5 cm of the ground at both frames (ground = the lowest
//     foot height of the clean clip, Y up);
//   - angular speed profile: RMS difference of |Log(q_t^-1 q_{t+1})| / frame_time over joints
//     and steps inside segments, rad/s.
//
// End effectors are found by name: joints whose names contain hand, wrist, foot, ankle or toe
// (any case); of each such group (side from a Left/Right or L/R prefix, limb hand|wrist or
// foot|ankle|toe) the deepest joint, at its End Site when it has one (CMU: LeftHandIndex1 and
// LeftToeBase End Sites). A skeleton without such names uses its chain ends (End Sites of the
// leaves), and feet are then the two lowest in the first scored frame.
//
// Units: --unit-cm gives cm per file unit. Otherwise it is guessed from the hip height (median
// root height above the lowest foot point of the clean clip): 12 to 25 units is a CMU-like file,
// 5.64 cm per unit (CMU's (1/0.45) * 2.54); anything else is taken as cm (1). The shared CMU
// clips measure 16.9 to 18.2 units, and 21.4 for 03_01 (uneven terrain: its lowest foot point
// lies below the floor it mostly walks on); a human hip is 70-110 cm, i.e. 12-20 CMU units, and
// no plausible cm, m or inch file falls in the range.
#include <cstdint>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/forward_kinematics.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/position_metrics.hpp"

namespace mocap::engine::eval {

inline constexpr double kCmuCmPerUnit = 2.54 / 0.45;
inline constexpr double kCmuHipHeightMin = 12, kCmuHipHeightMax = 25;  // file units
inline constexpr double kSkateStepCm = 2.5;
inline constexpr double kSkateHeightCm = 5.0;

struct Effector {
  std::string name;  // "LeftHandIndex1 (End Site)"
  JointSite site;
  bool foot = false;
};

// The skeleton's description for the position metrics (constant per clip).
struct ClipGeometry {
  std::vector<int> parents;
  std::vector<Vec3> offsets;
  std::vector<std::uint8_t> translated;  // joints with position channels
  std::vector<Effector> effectors;
  std::vector<JointSite> sites;  // effectors[i].site
  bool by_name = true;           // false: chain ends
  double unit_cm = 1;
  bool unit_guessed = true;
  // Joints that are not motion in the clean clip (kernels/joint_quality.hpp): left out of the
  // worst-error score.
  std::vector<std::uint8_t> garbage;
  double hip_height_units = 0;
  double body_height_units = 0;  // rest pose (kernels/foot_contacts.hpp, rest_height)
  std::vector<FootChain> feet;   // find_feet: their ankles carry the contacts and the skating
};

// The effectors of `clip`'s skeleton, the unit (unit_cm > 0: given), from the clean clip.
ClipGeometry describe_clip(const Clip& clean, double unit_cm, const std::vector<Segment>& segments);

// Scores as sums, so that clips pool by adding.
struct Score {
  double rotation_sq = 0;  // rad^2
  double rotation_n = 0;
  // The same over the samples that are no glitch of the reference (ClipReference::glitches): a
  // repair of a real glitch of the capture does not count as damage there.
  double unglitched_sq = 0, unglitched_n = 0;
  double effector_sq = 0;  // cm^2
  double effector_n = 0;
  double skate_steps = 0, foot_steps = 0;
  double speed_sq = 0;  // (rad/s)^2
  double speed_n = 0;
  double max_error = 0;  // rad: the largest rotation error of any joint that is not garbage
  // The peak angular speed of the knees (the parents of geometry.feet's ankles) over the scored
  // steps, as a ratio to the clean clip's peak (docs/feet.md: no knee pop); the largest over
  // pooled clips.
  double knee_peak_ratio = 0;
  // Joint positions of every joint (spec "Metrics"), in mm, over the scored frames of each segment
  // less kScoreEdgeSeconds at its ends (kernels/position_metrics.hpp): MPJPE, jitter, acceleration
  // error, and skating over the clean clip's foot contacts.
  PositionSums positions;

  void add(const Score& other);
  double rmse() const;             // rad
  double psnr() const;             // dB
  double unglitched_psnr() const;  // dB, over the samples that are no glitch of the reference
  double effector_rms_cm() const;  // cm
  double skating_percent() const;  // % of foot steps
  double speed_rms() const;        // rad/s
  double mpjpe_mm() const;
  double jitter_mm() const;       // RMS |P[t+1] - 2 P[t] + P[t-1]|, mm per frame^2
  double accel_error_mm() const;  // mm per frame^2
  double skating_mm() const;      // mm per frame over the clean clip's contact frames
};

// What the scores compare against, computed once from the clean clip.
struct ClipReference {
  std::vector<float> effectors;  // [F][E][3] global positions, file units
  std::vector<double> speeds;    // [J][F-1] angular speed of each joint, rad/s
  double ground = 0;             // lowest foot height (Y), file units
  Score clean_skating;           // the clean clip's own skating (skate_steps, foot_steps)
  std::vector<float> positions;  // [F][J][3] global joint positions of the clean clip
  std::vector<std::vector<ContactInterval>> contacts;  // per foot of geometry.feet
  PositionSums clean_positions;  // the clean clip's own jitter and skating, mm
  // [F][J], or empty: 1 where the clean clip itself has a glitch, a sample the pop stage flags on
  // its source at the source's own rate (one-frame jumps of the capture, eval_run.cpp
  // prepare_clip); Score's "unglitched" sums leave them out.
  std::vector<std::uint8_t> glitches;
};
ClipReference make_reference(const Clip& clean, const ClipGeometry& geometry,
                             const std::vector<Segment>& segments);

// The scores of `result` (rotations and translations of the clip's shape; empty translations:
// the clean clip's).
Score score_clip(const Clip& clean, const ClipGeometry& geometry, const ClipReference& reference,
                 const std::vector<Segment>& segments, RotationView result,
                 TranslationView result_translations = {});

// Global positions of the effectors for `rotations` with `translations` (empty: the clean
// clip's); `joints` (optional) receives every joint's.
void effector_positions(const Clip& clean, const ClipGeometry& geometry, RotationView rotations,
                        std::vector<float>& out, TranslationView translations = {},
                        std::vector<float>* joints = nullptr);

// Skating steps of one foot's track (global positions per frame, file units) over the steps
// inside segments of at least 2 frames: adds to *skates and *steps.
void count_skating(std::span<const Vec3> track, const std::vector<Segment>& segments, double ground,
                   double cm_per_unit, double* skates, double* steps);

}  // namespace mocap::engine::eval
