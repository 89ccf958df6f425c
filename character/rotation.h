// Rotation math for poses: quaternions (w, x, y, z), Euler decomposition onto hinge axes, and
// the heading frame. Pure functions; MuJoCo's mju_* routines do the elementary work.
#pragma once

#include <array>

#include "character/vector.h"

namespace ragdoll::character {

using Quat = std::array<double, 4>;  // (w, x, y, z), unit norm

inline constexpr Quat kIdentityQuat = {1, 0, 0, 0};

Quat Multiply(const Quat& a, const Quat& b);
Quat Conjugate(const Quat& q);
Quat Normalized(Quat q);
Quat AxisAngle(const Vec3& axis, double angle);
Vec3 Rotate(const Quat& q, const Vec3& v);
// Spherical linear interpolation along the shorter arc; alpha in [0, 1].
Quat Slerp(const Quat& a, Quat b, double alpha);
// The rotation angle in [0, pi] that takes a to b (the "quaternion difference" of DeepMimic).
double AngleBetween(const Quat& a, const Quat& b);
// Angular velocity, in the frame of `from`, that turns `from` into `to` in time dt.
Vec3 AngularVelocity(const Quat& from, const Quat& to, double dt);

// A joint of one to three hinges whose axes are signed coordinate axes, composed as intrinsic
// rotations in order: R = R(axis[0], q0) R(axis[1], q1) R(axis[2], q2). This is how MuJoCo
// composes several hinges in one body.
struct HingeAxes {
  int count = 0;        // 1 or 3
  int axis[3] = {};     // coordinate index 0, 1, 2 of each hinge
  double sign[3] = {};  // +1 or -1: the hinge turns about +axis or -axis
};

// The joint rotation for hinge angles q[0..count).
Quat ComposeHinges(const HingeAxes& axes, const double* q);
// Hinge angles that reproduce `rotation` as closely as the joint allows. Three hinges: exact
// (a Tait-Bryan decomposition; the middle angle lies in [-pi/2, pi/2]). One hinge: the twist of
// `rotation` about the hinge axis (swing-twist decomposition), in (-pi, pi].
void DecomposeHinges(const HingeAxes& axes, const Quat& rotation, double* q);

// Rotation about +z by the yaw of the rotation's forward (+x) axis: the "heading frame" in which
// observations are expressed, so that a policy is invariant to where the character faces.
Quat HeadingOf(const Quat& rotation);
double YawOf(const Quat& rotation);
// The yaw of the rotated forward (+x) and up (+z) axes' sum: where an upright body faces and
// where a lying one's head points, well defined in both (YawOf is not for a body lying face down
// or up, whose forward axis is near vertical).
double BodyYawOf(const Quat& rotation);
// An angle wrapped to [-pi, pi].
double WrapAngle(double radians);

}  // namespace ragdoll::character
