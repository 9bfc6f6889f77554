// The forward kinematics lanes (kernels/simd/forward_kinematics_simd.hpp) do core/quaternion's
// double operations in their order: every output double equals the scalar expression's to the
// bit, on every Highway target compiled in. (The job's float outputs hide most rounding changes;
// this compares before the rounding to float.)
#include "kernels/simd/forward_kinematics_simd.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "hwy/highway.h"
#include "hwy/tests/hwy_gtest.h"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

class ForwardKinematicsSimd : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(ForwardKinematicsSimd);

bool same_bits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST_P(ForwardKinematicsSimd, LanesAreTheScalarExpressionsBitForBit) {
  constexpr std::size_t n = 40, stride = 48;  // 40: five vectors of 8, ten of 4
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<double> parent(7 * stride), rotation(4 * stride), translation(3 * stride);
  std::vector<Quat> parent_q(n), local_q(n);
  std::vector<Vec3> parent_p(n), local_t(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Unit rotations as the job passes them (floats widened), the identity and a half turn
    // among them, whose zero components make signed zeros.
    parent_q[i] = i == 3 ? Quat{} : i == 4 ? Quat{0, 0, 1, 0} : test::random_rotation(rng);
    float f[4];
    store_quat(test::random_rotation(rng), f);
    local_q[i] = i == 5 ? Quat{} : load_quat(f);
    parent_p[i] = {u(rng), u(rng), u(rng)};
    local_t[i] = i == 6 ? Vec3{0, -0.0, 0} : Vec3{u(rng), u(rng), u(rng)};
    const double pq[7] = {parent_q[i].w, parent_q[i].x, parent_q[i].y, parent_q[i].z,
                          parent_p[i].x, parent_p[i].y, parent_p[i].z};
    for (std::size_t c = 0; c < 7; ++c) parent[c * stride + i] = pq[c];
    const double lq[4] = {local_q[i].w, local_q[i].x, local_q[i].y, local_q[i].z};
    for (std::size_t c = 0; c < 4; ++c) rotation[c * stride + i] = lq[c];
    const double lt[3] = {local_t[i].x, local_t[i].y, local_t[i].z};
    for (std::size_t c = 0; c < 3; ++c) translation[c * stride + i] = lt[c];
  }
  const Vec3 offset{0.5, 0, -3};
  std::vector<double> joint(7 * stride), site(3 * stride);
  for (const bool per_frame : {false, true}) {
    simd::forward_kinematics_joint(parent.data(), rotation.data(),
                                   per_frame ? translation.data() : nullptr, offset, joint.data(),
                                   n, stride);
    simd::forward_kinematics_site(joint.data(), offset, site.data(), n, stride);
    for (std::size_t i = 0; i < n; ++i) {
      const Quat r = parent_q[i] * local_q[i];
      const Vec3 p = parent_p[i] + rotate(parent_q[i], per_frame ? local_t[i] : offset);
      const Vec3 s = p + rotate(r, offset);
      const double expected[10] = {r.w, r.x, r.y, r.z, p.x, p.y, p.z, s.x, s.y, s.z};
      for (std::size_t c = 0; c < 10; ++c) {
        const double got = c < 7 ? joint[c * stride + i] : site[(c - 7) * stride + i];
        EXPECT_TRUE(same_bits(got, expected[c]))
            << "lane " << i << ", component " << c << (per_frame ? ", translated" : ", offset")
            << ": " << got << " vs " << expected[c];
      }
    }
  }
  // A root: its frame is its local rotation and translation.
  simd::forward_kinematics_joint(nullptr, rotation.data(), translation.data(), offset, joint.data(),
                                 n, stride);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(same_bits(joint[i], local_q[i].w)) << "root lane " << i;
    EXPECT_TRUE(same_bits(joint[4 * stride + i], local_t[i].x)) << "root lane " << i;
  }
}

}  // namespace
}  // namespace mocap
