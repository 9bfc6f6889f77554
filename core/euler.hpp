#pragma once
// Euler angles <-> quaternions for the six Tait-Bryan orders of BVH channel lists.
// An order names the axes as they appear in the file: "Zrotation Xrotation Yrotation" is ZXY and
// means q = Rz(a0) * Rx(a1) * Ry(a2) (intrinsic rotations, applied to column vectors).
#include <array>
#include <optional>
#include <string_view>

#include "core/quaternion.hpp"

namespace mocap {

enum class RotationOrder { XYZ, XZY, YXZ, YZX, ZXY, ZYX };

// The axis (0 = x, 1 = y, 2 = z) at position i of the order.
int order_axis(RotationOrder order, int i);
std::string_view to_string(RotationOrder order);
// From three axes in file order (each 0, 1, 2, all different).
RotationOrder order_from_axes(int a0, int a1, int a2);

using EulerAngles = std::array<double, 3>;  // radians, in the order's own sequence

Quat euler_to_quat(RotationOrder order, const EulerAngles& angles);

// The Euler angles of q. With `previous`, the solution (of the two, each shifted by multiples of
// 2 pi) closest to it, so curves stay continuous along time; at gimbal lock the third angle keeps
// its previous value.
EulerAngles quat_to_euler(RotationOrder order, Quat q,
                          const std::optional<EulerAngles>& previous = std::nullopt);

}  // namespace mocap
