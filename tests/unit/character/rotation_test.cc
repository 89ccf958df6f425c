#include "character/rotation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace ragdoll::character {
namespace {

constexpr double kDeg = M_PI / 180;

Vec3 Unit(const Vec3& v) {
  double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}

// Component-wise comparison; q and -q are different here (used where the sign is specified).
void ExpectQuatEq(const Quat& actual, const Quat& expected, double tolerance) {
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(actual[i], expected[i], tolerance) << "component " << i;
  }
}

// Comparison of rotations: q and -q are the same rotation.
void ExpectSameRotation(const Quat& actual, const Quat& expected, double tolerance) {
  double dot = 0;
  for (int i = 0; i < 4; ++i) dot += actual[i] * expected[i];
  double s = dot < 0 ? -1 : 1;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(actual[i], s * expected[i], tolerance) << "component " << i;
  }
}

Quat Negated(const Quat& q) { return {-q[0], -q[1], -q[2], -q[3]}; }

TEST(Slerp, ReturnsTheEndpoints) {
  Quat a = AxisAngle(Unit({1, 2, 3}), 0.7);
  Quat b = AxisAngle(Unit({-1, 0.5, 2}), 1.9);
  ExpectQuatEq(Slerp(a, b, 0), a, 1e-15);
  ExpectSameRotation(Slerp(a, b, 1), b, 1e-12);
}

TEST(Slerp, MidpointOfAQuarterTurnIsAnEighthTurn) {
  // identity to 90 degrees about z; halfway is 45 degrees about z: (cos 22.5deg, 0, 0, sin 22.5deg)
  Quat mid = Slerp(kIdentityQuat, AxisAngle({0, 0, 1}, M_PI / 2), 0.5);
  ExpectQuatEq(mid, {std::cos(M_PI / 8), 0, 0, std::sin(M_PI / 8)}, 1e-12);
  // A quarter of the way from identity to 170 degrees is 42.5 degrees.
  Quat quarter = Slerp(kIdentityQuat, AxisAngle({0, 0, 1}, 170 * kDeg), 0.25);
  ExpectQuatEq(quarter, AxisAngle({0, 0, 1}, 42.5 * kDeg), 1e-12);
}

TEST(Slerp, TakesTheShorterArc) {
  // -q is the same quarter turn; the midpoint must still be +45 degrees, on a's side.
  Quat mid = Slerp(kIdentityQuat, Negated(AxisAngle({0, 0, 1}, M_PI / 2)), 0.5);
  ExpectQuatEq(mid, {std::cos(M_PI / 8), 0, 0, std::sin(M_PI / 8)}, 1e-12);
  // +170 and -170 degrees about z are 20 degrees apart through 180; the long way round (340
  // degrees) would pass through the identity instead.
  Quat across = Slerp(AxisAngle({0, 0, 1}, 170 * kDeg), AxisAngle({0, 0, 1}, -170 * kDeg), 0.5);
  EXPECT_NEAR(AngleBetween(across, AxisAngle({0, 0, 1}, M_PI)), 0, 1e-12);
  Quat quarter = Slerp(AxisAngle({0, 0, 1}, 170 * kDeg), AxisAngle({0, 0, 1}, -170 * kDeg), 0.25);
  EXPECT_NEAR(AngleBetween(quarter, AxisAngle({0, 0, 1}, 175 * kDeg)), 0, 1e-12);
}

TEST(Slerp, TurnsAtConstantRateAboutOneAxis) {
  Quat a = AxisAngle(Unit({1, 2, 3}), 0.7);
  Quat b = AxisAngle(Unit({-1, 0.5, 2}), 1.9);
  // The relative rotation a^-1 b as axis and angle.
  Quat d = Multiply(Conjugate(a), b);
  if (d[0] < 0) d = Negated(d);
  double angle = 2 * std::atan2(std::sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3]), d[0]);
  Vec3 axis = Unit({d[1], d[2], d[3]});
  ASSERT_GT(angle, 0.5);  // well inside the slerp branch, not the linear one
  for (double t : {0.1, 0.3, 0.5, 0.9}) {
    Quat q = Slerp(a, b, t);
    ExpectSameRotation(q, Multiply(a, AxisAngle(axis, t * angle)), 1e-12);
    EXPECT_NEAR(AngleBetween(a, q), t * angle, 1e-12) << t;
    EXPECT_NEAR(AngleBetween(q, b), (1 - t) * angle, 1e-12) << t;
  }
}

TEST(Slerp, NearlyParallelQuaternionsInterpolateAccurately) {
  // 0.02 rad apart: the linear branch; a quarter of the way is 0.005 rad.
  Quat q = Slerp(kIdentityQuat, AxisAngle({0, 0, 1}, 0.02), 0.25);
  EXPECT_NEAR(AngleBetween(q, AxisAngle({0, 0, 1}, 0.005)), 0, 1e-7);
  EXPECT_NEAR(std::hypot(std::hypot(q[0], q[1]), std::hypot(q[2], q[3])), 1, 1e-15);
}

TEST(AngleBetween, KnownAngles) {
  EXPECT_NEAR(AngleBetween(kIdentityQuat, AxisAngle({0, 1, 0}, 0.7)), 0.7, 1e-12);
  EXPECT_NEAR(AngleBetween(AxisAngle({0, 1, 0}, 0.7), kIdentityQuat), 0.7, 1e-12);
  EXPECT_NEAR(AngleBetween(kIdentityQuat, AxisAngle({1, 0, 0}, M_PI)), M_PI, 1e-12);
  // 3 and -3 rad about z are 2 pi - 6 = 0.2832 rad apart the short way.
  EXPECT_NEAR(AngleBetween(AxisAngle({0, 0, 1}, 3), AxisAngle({0, 0, 1}, -3)), 2 * M_PI - 6, 1e-12);
  // The same relative turn after a common rotation c: c a and c b are as far apart as a and b.
  Quat c = AxisAngle(Unit({0.3, -1, 0.2}), 2.2);
  Quat a = AxisAngle(Unit({1, 1, 0}), 0.4);
  Quat b = Multiply(a, AxisAngle(Unit({0, 1, 1}), 1.1));
  EXPECT_NEAR(AngleBetween(Multiply(c, a), Multiply(c, b)), 1.1, 1e-12);
}

TEST(AngleBetween, QAndMinusQAreTheSameRotation) {
  Quat q = AxisAngle(Unit({1, -2, 0.5}), 2.5);
  EXPECT_NEAR(AngleBetween(q, Negated(q)), 0, 1e-12);
  EXPECT_NEAR(AngleBetween(Negated(q), q), 0, 1e-12);
  EXPECT_NEAR(AngleBetween(kIdentityQuat, Negated(AxisAngle({0, 0, 1}, 0.3))), 0.3, 1e-12);
}

TEST(AngularVelocity, QuarterTurnInHalfASecondIsPiRadPerSecond) {
  // 90 degrees about x in 0.5 s: (pi / 2) / 0.5 = pi rad/s about x.
  Vec3 w = AngularVelocity(kIdentityQuat, AxisAngle({1, 0, 0}, M_PI / 2), 0.5);
  EXPECT_NEAR(w[0], M_PI, 1e-12);
  EXPECT_NEAR(w[1], 0, 1e-12);
  EXPECT_NEAR(w[2], 0, 1e-12);
  // The sign of the target quaternion does not matter.
  Vec3 w_neg = AngularVelocity(kIdentityQuat, Negated(AxisAngle({1, 0, 0}, M_PI / 2)), 0.5);
  EXPECT_NEAR(w_neg[0], M_PI, 1e-12);
  EXPECT_NEAR(w_neg[1], 0, 1e-12);
  EXPECT_NEAR(w_neg[2], 0, 1e-12);
}

TEST(AngularVelocity, IsExpressedInTheFrameOfFrom) {
  // `from` faces +y (90 degrees about z); turning 0.3 rad about its own x axis in 0.1 s is 3 rad/s
  // about local x (world y would be (0, 3, 0)).
  Quat from = AxisAngle({0, 0, 1}, M_PI / 2);
  Quat to = Multiply(from, AxisAngle({1, 0, 0}, 0.3));
  Vec3 w = AngularVelocity(from, to, 0.1);
  EXPECT_NEAR(w[0], 3, 1e-12);
  EXPECT_NEAR(w[1], 0, 1e-12);
  EXPECT_NEAR(w[2], 0, 1e-12);
  Vec3 still = AngularVelocity(from, from, 0.1);
  for (double c : still) EXPECT_NEAR(c, 0, 1e-15);
}

TEST(ComposeHinges, ComposesIntrinsicallyInAxisOrder) {
  // R = Rz(90deg) Rx(90deg): Rx takes +z to -y, then Rz takes -y to +x.
  HingeAxes axes{3, {2, 0, 1}, {1, 1, 1}};
  double q[3] = {M_PI / 2, M_PI / 2, 0};
  Vec3 z = Rotate(ComposeHinges(axes, q), {0, 0, 1});
  EXPECT_NEAR(z[0], 1, 1e-12);
  EXPECT_NEAR(z[1], 0, 1e-12);
  EXPECT_NEAR(z[2], 0, 1e-12);
  // With the x hinge reversed: Rx(-90deg) takes +z to +y, then Rz takes +y to -x.
  axes.sign[1] = -1;
  z = Rotate(ComposeHinges(axes, q), {0, 0, 1});
  EXPECT_NEAR(z[0], -1, 1e-12);
  EXPECT_NEAR(z[1], 0, 1e-12);
  EXPECT_NEAR(z[2], 0, 1e-12);
  // One hinge about -y by 0.4 rad.
  HingeAxes knee{1, {1, 0, 0}, {-1, 0, 0}};
  double angle = 0.4;
  ExpectQuatEq(ComposeHinges(knee, &angle), AxisAngle({0, -1, 0}, 0.4), 1e-15);
}

TEST(DecomposeHinges, RoundTripsEveryAxisOrderAndSign) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> outer(-3.1, 3.1);   // first and last: (-pi, pi)
  std::uniform_real_distribution<double> middle(-1.5, 1.5);  // (-pi/2, pi/2), off gimbal lock
  int order[3] = {0, 1, 2};
  int orders = 0;
  do {
    ++orders;
    for (int signs = 0; signs < 8; ++signs) {
      HingeAxes axes{3, {order[0], order[1], order[2]}, {1, 1, 1}};
      for (int h = 0; h < 3; ++h) axes.sign[h] = (signs >> h) & 1 ? -1.0 : 1.0;
      std::string label = "axes " + std::to_string(order[0]) + std::to_string(order[1]) +
                          std::to_string(order[2]) + " signs " + std::to_string(signs);
      for (int trial = 0; trial < 200; ++trial) {
        double q[3] = {outer(rng), middle(rng), outer(rng)};
        double back[3];
        DecomposeHinges(axes, ComposeHinges(axes, q), back);
        for (int h = 0; h < 3; ++h) {
          ASSERT_NEAR(back[h], q[h], 1e-9)
              << label << " hinge " << h << " angles " << q[0] << " " << q[1] << " " << q[2];
        }
        // The quaternion's sign must not matter.
        Quat negated = Negated(ComposeHinges(axes, q));
        DecomposeHinges(axes, negated, back);
        for (int h = 0; h < 3; ++h) ASSERT_NEAR(back[h], q[h], 1e-9) << label << " (-q)";
      }
    }
  } while (std::next_permutation(order, order + 3));
  EXPECT_EQ(orders, 6);
}

TEST(DecomposeHinges, OneHingeRecoversTheTwist) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-3.1, 3.1);
  for (int a = 0; a < 3; ++a) {
    for (double sign : {1.0, -1.0}) {
      HingeAxes axes{1, {a, 0, 0}, {sign, 0, 0}};
      // A swing about an axis perpendicular to the hinge.
      Vec3 perpendicular = {0, 0, 0};
      perpendicular[(a + 1) % 3] = 1;
      Quat swing = AxisAngle(perpendicular, 0.6);
      for (int trial = 0; trial < 50; ++trial) {
        double q = angle(rng);
        Quat twist = ComposeHinges(axes, &q);
        double back = 0;
        DecomposeHinges(axes, twist, &back);
        EXPECT_NEAR(back, q, 1e-12) << "axis " << a << " sign " << sign;
        DecomposeHinges(axes, Negated(twist), &back);
        EXPECT_NEAR(back, q, 1e-12) << "axis " << a << " sign " << sign << " (-q)";
        // swing * twist and twist * swing both have exactly this twist about the hinge axis.
        DecomposeHinges(axes, Multiply(swing, twist), &back);
        EXPECT_NEAR(back, q, 1e-12) << "axis " << a << " sign " << sign << " swing first";
        DecomposeHinges(axes, Multiply(twist, swing), &back);
        EXPECT_NEAR(back, q, 1e-12) << "axis " << a << " sign " << sign << " swing last";
      }
    }
  }
}

TEST(Heading, YawOfTurnsAboutZ) {
  EXPECT_NEAR(YawOf(kIdentityQuat), 0, 1e-15);
  EXPECT_NEAR(YawOf(AxisAngle({0, 0, 1}, 0.8)), 0.8, 1e-12);
  // Pitch (local y) and roll (local x) do not change where the forward axis points horizontally.
  EXPECT_NEAR(YawOf(Multiply(AxisAngle({0, 0, 1}, 0.8), AxisAngle({0, 1, 0}, 0.5))), 0.8, 1e-12);
  EXPECT_NEAR(YawOf(Multiply(AxisAngle({0, 0, 1}, -2.5), AxisAngle({1, 0, 0}, 1.0))), -2.5, 1e-12);
  // Wrapped into (-pi, pi]: 3.5 rad is 3.5 - 2 pi = -2.7832 rad.
  EXPECT_NEAR(YawOf(AxisAngle({0, 0, 1}, 3.5)), 3.5 - 2 * M_PI, 1e-12);
}

TEST(Heading, HeadingOfKeepsOnlyTheYaw) {
  Quat q = Multiply(AxisAngle({0, 0, 1}, 0.8), AxisAngle(Unit({1, 1, 0}), 0.5));
  ExpectQuatEq(HeadingOf(q), AxisAngle({0, 0, 1}, YawOf(q)), 1e-15);
  ExpectQuatEq(HeadingOf(Multiply(AxisAngle({0, 0, 1}, 0.8), AxisAngle({0, 1, 0}, 0.5))),
               {std::cos(0.4), 0, 0, std::sin(0.4)}, 1e-12);
  // In its own heading frame a rotation faces +x: zero yaw left.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Quat r = AxisAngle(Unit({u(rng), u(rng), u(rng)}), 3 * u(rng));
    EXPECT_NEAR(YawOf(Multiply(Conjugate(HeadingOf(r)), r)), 0, 1e-12);
  }
}

}  // namespace
}  // namespace ragdoll::character
