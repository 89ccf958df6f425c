#include "character/rotation.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>

namespace ragdoll::character {

Quat Multiply(const Quat& a, const Quat& b) {
  Quat r;
  mju_mulQuat(r.data(), a.data(), b.data());
  return r;
}

Quat Conjugate(const Quat& q) { return {q[0], -q[1], -q[2], -q[3]}; }

Quat Normalized(Quat q) {
  mju_normalize4(q.data());
  return q;
}

Quat AxisAngle(const Vec3& axis, double angle) {
  Quat r;
  mju_axisAngle2Quat(r.data(), axis.data(), angle);
  return r;
}

Vec3 Rotate(const Quat& q, const Vec3& v) {
  Vec3 r;
  mju_rotVecQuat(r.data(), v.data(), q.data());
  return r;
}

Quat Slerp(const Quat& a, Quat b, double alpha) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0) {  // q and -q are the same rotation; take the shorter arc
    for (double& c : b) c = -c;
    dot = -dot;
  }
  double wa, wb;
  if (dot > 0.9995) {  // nearly parallel: linear interpolation is within ~1e-6 rad and stable
    wa = 1 - alpha;
    wb = alpha;
  } else {
    double theta = std::acos(dot);
    double s = std::sin(theta);
    wa = std::sin((1 - alpha) * theta) / s;
    wb = std::sin(alpha * theta) / s;
  }
  Quat r;
  for (int i = 0; i < 4; ++i) r[i] = wa * a[i] + wb * b[i];
  return Normalized(r);
}

double AngleBetween(const Quat& a, const Quat& b) {
  Quat d = Multiply(Conjugate(a), b);
  double v = std::sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3]);
  return 2 * std::atan2(v, std::abs(d[0]));
}

Vec3 AngularVelocity(const Quat& from, const Quat& to, double dt) {
  Vec3 r;
  mju_subQuat(r.data(), to.data(), from.data());
  for (double& c : r) c /= dt;
  return r;
}

Quat ComposeHinges(const HingeAxes& axes, const double* q) {
  Quat r = kIdentityQuat;
  for (int i = 0; i < axes.count; ++i) {
    Vec3 axis = {0, 0, 0};
    axis[axes.axis[i]] = axes.sign[i];
    r = Multiply(r, AxisAngle(axis, q[i]));
  }
  return r;
}

void DecomposeHinges(const HingeAxes& axes, const Quat& rotation, double* q) {
  if (axes.count == 1) {
    int a = axes.axis[0];
    double twist = 2 * std::atan2(rotation[1 + a], rotation[0]);
    if (twist > M_PI) twist -= 2 * M_PI;
    if (twist <= -M_PI) twist += 2 * M_PI;
    q[0] = axes.sign[0] * twist;
    return;
  }
  // Tait-Bryan angles for R = R_i(a) R_j(b) R_k(c) about unsigned axes i, j, k; `parity` is +1
  // for a cyclic order (xyz, yzx, zxy) and -1 otherwise.
  double m[9];
  mju_quat2Mat(m, rotation.data());
  auto at = [&m](int row, int col) { return m[3 * row + col]; };
  int i = axes.axis[0], j = axes.axis[1], k = axes.axis[2];
  double parity = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  double b = std::asin(std::clamp(parity * at(i, k), -1.0, 1.0));
  double a = std::atan2(-parity * at(j, k), at(k, k));
  double c = std::atan2(-parity * at(i, j), at(i, i));
  q[0] = axes.sign[0] * a;
  q[1] = axes.sign[1] * b;
  q[2] = axes.sign[2] * c;
}

double YawOf(const Quat& rotation) {
  Vec3 forward = Rotate(rotation, {1, 0, 0});
  return std::atan2(forward[1], forward[0]);
}

double BodyYawOf(const Quat& rotation) {
  const Vec3 forward = Rotate(rotation, {1, 0, 0});
  const Vec3 up = Rotate(rotation, {0, 0, 1});
  return std::atan2(forward[1] + up[1], forward[0] + up[0]);
}

double WrapAngle(double radians) { return std::remainder(radians, 2 * M_PI); }

Quat HeadingOf(const Quat& rotation) { return AxisAngle({0, 0, 1}, YawOf(rotation)); }

}  // namespace ragdoll::character
