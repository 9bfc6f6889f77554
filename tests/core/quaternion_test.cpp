// Property tests of the quaternion core (spec "Conventions") and the Euler conversions.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/euler.hpp"
#include "core/quaternion.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

double quat_distance(Quat a, Quat b) {
  return geodesic(a, b);
}

TEST(Quaternion, ProductMatchesKnownRotations) {
  const Quat rx90 = exp({kPi / 2, 0, 0});
  const Vec3 y = rotate(rx90, {0, 1, 0});
  EXPECT_NEAR(y.x, 0, 1e-15);
  EXPECT_NEAR(y.y, 0, 1e-15);
  EXPECT_NEAR(y.z, 1, 1e-15);
  // Hamilton order: (a * b) v = a (b v).
  std::mt19937_64 rng(1);
  for (int i = 0; i < 100; ++i) {
    const Quat a = test::random_rotation(rng), b = test::random_rotation(rng);
    const Vec3 v{0.3, -1.2, 0.7};
    const Vec3 lhs = rotate(a * b, v), rhs = rotate(a, rotate(b, v));
    EXPECT_NEAR(norm(lhs - rhs), 0, 1e-14);
  }
}

TEST(Quaternion, InverseUndoesProduct) {
  std::mt19937_64 rng(2);
  for (int i = 0; i < 100; ++i) {
    const Quat a = test::random_rotation(rng);
    EXPECT_NEAR(angle(a * inverse(a)), 0, 1e-7);
    EXPECT_NEAR(angle(inverse(a) * a), 0, 1e-7);
  }
}

TEST(Quaternion, LogExpRoundTripAcrossAngles) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double theta : {0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.5, 2.0, kPi - 1e-3, kPi - 1e-7}) {
    for (int i = 0; i < 20; ++i) {
      Vec3 axis{u(rng), u(rng), u(rng)};
      axis = (1.0 / norm(axis)) * axis;
      const Vec3 v = theta * axis;
      const Vec3 back = log(exp(v));
      EXPECT_NEAR(norm(back - v), 0, 1e-12 + 1e-12 * theta) << "theta " << theta;
    }
  }
}

TEST(Quaternion, LogHasFullAngleAndIgnoresSign) {
  const Quat q = exp({0, 0, 1.25});
  EXPECT_NEAR(log(q).z, 1.25, 1e-15);
  EXPECT_NEAR(log(negate(q)).z, 1.25, 1e-15);  // q and -q are one rotation
  EXPECT_NEAR(angle(q), 1.25, 1e-15);
}

TEST(Quaternion, GeodesicIsAccurateForSmallAnglesInFloat) {
  // Against the exact value: the angle of a^-1 b for b = a Exp(v) is |v|.
  std::mt19937_64 rng(4);
  for (double theta : {1e-6, 1e-5, 1e-4, 1e-3, 1e-2}) {
    const Quat a = test::random_rotation(rng);
    const Quat b = a * exp({theta * 0.6, theta * 0.8, 0});
    // Round to float as tensors are stored; the distance must still be near theta.
    float fa[4], fb[4];
    store_quat(a, fa);
    store_quat(b, fb);
    const double d = geodesic(load_quat(fa), load_quat(fb));
    EXPECT_NEAR(d, theta, 1e-6) << "theta " << theta;
    EXPECT_NEAR(geodesic(a, b), theta, 1e-13 + 1e-9 * theta);
  }
}

TEST(Quaternion, GeodesicNearPi) {
  const Quat a{};
  EXPECT_NEAR(geodesic(a, exp({kPi - 1e-4, 0, 0})), kPi - 1e-4, 1e-9);
  EXPECT_NEAR(geodesic(a, exp({kPi, 0, 0})), kPi, 1e-7);
}

TEST(Quaternion, HemisphereContinuity) {
  std::vector<float> q = {1, 0, 0, 0, -0.99f, -0.1f, 0, 0, 0.98f, 0.2f, 0, 0};
  make_hemisphere_continuous({q.data(), 3, 1});
  EXPECT_GT(q[4], 0);
  EXPECT_GT(q[8], 0);
  EXPECT_FLOAT_EQ(q[5], 0.1f);
}

class EulerOrders : public ::testing::TestWithParam<RotationOrder> {};

TEST_P(EulerOrders, RoundTripAndComposition) {
  const RotationOrder order = GetParam();
  std::mt19937_64 rng(5 + int(order));
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int i = 0; i < 500; ++i) {
    const EulerAngles e{u(rng), 0.5 * u(rng), u(rng)};
    const Quat q = euler_to_quat(order, e);
    const EulerAngles back = quat_to_euler(order, q);
    // Conditioning worsens as |b| -> pi/2 (atan2 of cos b-sized terms); BVH needs 1e-6 rad.
    EXPECT_LT(quat_distance(euler_to_quat(order, back), q), 1e-10);
    EXPECT_NEAR(back[1], e[1], 1e-9);  // middle angle within (-pi/2, pi/2) is unique
  }
  // Composition follows the file order: R_first * R_second * R_third.
  const EulerAngles e{0.3, -0.2, 1.1};
  Quat expected{};
  for (int i = 0; i < 3; ++i) {
    Vec3 axis{};
    (order_axis(order, i) == 0 ? axis.x : order_axis(order, i) == 1 ? axis.y : axis.z) = e[i];
    expected = expected * exp(axis);
  }
  EXPECT_LT(quat_distance(euler_to_quat(order, e), expected), 1e-14);
}

TEST_P(EulerOrders, GimbalLockStillReproducesRotation) {
  const RotationOrder order = GetParam();
  for (double b : {kPi / 2, -kPi / 2, kPi / 2 - 1e-9}) {
    const Quat q = euler_to_quat(order, {0.7, b, -0.4});
    const EulerAngles back = quat_to_euler(order, q, EulerAngles{0.1, 1.5, -0.4});
    EXPECT_LT(quat_distance(euler_to_quat(order, back), q), 1e-7);
  }
}

TEST_P(EulerOrders, ContinuousAlongASpin) {
  // A spin about the first axis by 6 pi: continuity must unwrap it with no 2 pi jumps.
  const RotationOrder order = GetParam();
  EulerAngles prev = quat_to_euler(order, euler_to_quat(order, {0, 0.3, 0.2}));
  for (int t = 1; t <= 600; ++t) {
    const double a = 6 * kPi * t / 600.0;
    const Quat q = euler_to_quat(order, {a, 0.3, 0.2});
    const EulerAngles e = quat_to_euler(order, q, prev);
    for (int c = 0; c < 3; ++c) EXPECT_LT(std::abs(e[c] - prev[c]), 0.1) << "t " << t;
    EXPECT_LT(quat_distance(euler_to_quat(order, e), q), 1e-12);
    prev = e;
  }
  EXPECT_NEAR(prev[0], 6 * kPi, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(AllSix, EulerOrders,
                         ::testing::Values(RotationOrder::XYZ, RotationOrder::XZY,
                                           RotationOrder::YXZ, RotationOrder::YZX,
                                           RotationOrder::ZXY, RotationOrder::ZYX),
                         [](const auto& p) { return std::string(to_string(p.param)); });

}  // namespace
}  // namespace mocap
