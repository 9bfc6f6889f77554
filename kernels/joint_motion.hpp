#pragma once
// How fast each joint of a clip moves, seen through its noise: the measure behind auto's
// per-joint cut-off (engine/clip/filter_settings.hpp, automatic_joint_cutoffs).
//
//     P_j = mean over t and the 3 components of a_j(t)^2,
//     a_j(t) = v_j(t + L) - v_j(t),  v_j(t) = Log(q_j(t)^-1 q_j(t + L)),
//
// the lag-L second difference of joint j's rotation curve, over every t with [t, t + 2L] inside
// one segment. I.i.d. tangent noise of deviation sigma adds n(t + 2L) - 2 n(t + L) + n(t) to each
// component, 6 sigma^2 to P_j (as in the noise estimate's second difference, with L = 1), so
// P_j - 6 sigma^2 is what the joint's own motion brings.
#include <span>
#include <vector>

#include "core/tensor.hpp"
#include "kernels/motion_split.hpp"

namespace mocap {

// P_j for every joint (0 for a joint with no t), over `segments` (frames [begin, end) of the
// clip, each inside it; empty: the whole clip as one). lag >= 1.
std::vector<double> lagged_acceleration_power(RotationView rotations, int lag,
                                              std::span<const Segment> segments = {});

}  // namespace mocap
