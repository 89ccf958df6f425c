#include "character/motion_clip.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "character/skeleton.h"

namespace ragdoll::character {
namespace {

// Rotations in clip files are often not quite unit quaternions: DeepMimic's published motions
// carry norms from about 0.85 to 1.15, and DeepMimic normalises them on reading. So does this
// reader. Only a rotation that cannot be meant as one is refused: not finite, or a norm this far
// from 1 (a zero quaternion, a wrong column, a scale of 2).
constexpr double kMaxNormDeviation = 0.5;
// Six decimals in a file leave norms off by up to ~1e-6; past this a rotation was denormalised.
constexpr double kRoundingTolerance = 1e-3;

}  // namespace

Quat MotionClip::Renormalize(const Quat& q, int frame, const std::string& field) {
  double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!std::isfinite(norm)) {
    throw std::invalid_argument("frame " + std::to_string(frame) + ": " + field +
                                ": quaternion is not finite");
  }
  double deviation = std::abs(norm - 1);
  if (deviation > kMaxNormDeviation) {
    throw std::invalid_argument("frame " + std::to_string(frame) + ": " + field +
                                ": quaternion norm " + std::to_string(norm) +
                                " is too far from 1 to be a rotation (accepted: 0.5 to 1.5)");
  }
  if (deviation > kRoundingTolerance) ++renormalized_rotations_;
  max_norm_deviation_ = std::max(max_norm_deviation_, deviation);
  return {q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm};
}

MotionClip::MotionClip(std::string name, bool loop, std::vector<double> frame_durations,
                       std::vector<Pose> frames, CycleTransform cycle)
    : name_(std::move(name)),
      loop_(loop),
      durations_(std::move(frame_durations)),
      frames_(std::move(frames)),
      cycle_transform_(cycle) {
  if (frames_.size() < 2) {
    throw std::invalid_argument("a clip needs at least two frames, got " +
                                std::to_string(frames_.size()));
  }
  if (durations_.size() != frames_.size()) {
    throw std::invalid_argument("got " + std::to_string(durations_.size()) +
                                " frame durations for " + std::to_string(frames_.size()) +
                                " frames");
  }
  const auto& joints = Humanoid3dJoints();
  start_times_.assign(1, 0.0);
  for (size_t i = 0; i < frames_.size(); ++i) {
    int f = static_cast<int>(i);
    Pose& pose = frames_[i];
    if (i + 1 < frames_.size()) {
      if (!std::isfinite(durations_[i]) || durations_[i] <= 0) {
        throw std::invalid_argument("frame " + std::to_string(f) +
                                    ": duration must be positive, got " +
                                    std::to_string(durations_[i]));
      }
      start_times_.push_back(start_times_.back() + durations_[i]);
    }
    for (double c : pose.root_position) {
      if (!std::isfinite(c)) {
        throw std::invalid_argument("frame " + std::to_string(f) + ": root position is not finite");
      }
    }
    if (pose.joint_rotations.size() != joints.size()) {
      throw std::invalid_argument("frame " + std::to_string(f) + ": expected " +
                                  std::to_string(joints.size()) + " joint rotations, got " +
                                  std::to_string(pose.joint_rotations.size()));
    }
    pose.root_rotation = Renormalize(pose.root_rotation, f, "root rotation");
    for (size_t j = 0; j < joints.size(); ++j) {
      pose.joint_rotations[j] = Renormalize(pose.joint_rotations[j], f, joints[j].name);
    }
  }
  if (loop_) {
    const Vec3& first = frames_.front().root_position;
    const Vec3& last = frames_.back().root_position;
    cycle_displacement_ = {last[0] - first[0], last[1] - first[1], 0};
    cycle_pivot_ = {first[0], first[1], 0};
    if (cycle_transform_ == CycleTransform::kPlanar) {
      cycle_yaw_ = std::remainder(
          YawOf(frames_.back().root_rotation) - YawOf(frames_.front().root_rotation), 2 * M_PI);
    }
  }
}

void MotionClip::ApplyCycles(double cycles, Vec3* position, Quat* rotation) const {
  if (cycle_yaw_ == 0) {  // a translation
    for (int k = 0; k < 3; ++k) (*position)[k] += cycles * cycle_displacement_[k];
    return;
  }
  // T^k(p) = c + R^k (p - c) + S_k d, with c the pivot, R the turn by cycle_yaw(), d the
  // displacement, and S_k = R^0 + ... + R^(k-1) (for k < 0: -(R^k + ... + R^-1)), which as a
  // complex number is exp(i (k - 1) yaw / 2) sin(k yaw / 2) / sin(yaw / 2).
  const double turn = cycles * cycle_yaw_;
  const double c = std::cos(turn), s = std::sin(turn);
  const double gain = std::sin(turn / 2) / std::sin(cycle_yaw_ / 2);
  const double along = (cycles - 1) * cycle_yaw_ / 2;
  const double sc = gain * std::cos(along), ss = gain * std::sin(along);
  const double x = (*position)[0] - cycle_pivot_[0], y = (*position)[1] - cycle_pivot_[1];
  const double dx = cycle_displacement_[0], dy = cycle_displacement_[1];
  (*position)[0] = cycle_pivot_[0] + c * x - s * y + sc * dx - ss * dy;
  (*position)[1] = cycle_pivot_[1] + s * x + c * y + ss * dx + sc * dy;
  *rotation = Multiply(AxisAngle({0, 0, 1}, turn), *rotation);
}

void MotionClip::Locate(double time, int* index, double* alpha, double* cycles) const {
  double d = duration();
  *cycles = 0;
  if (loop_) {
    *cycles = std::floor(time / d);
    time -= *cycles * d;
  } else {
    time = std::fmin(std::fmax(time, 0.0), d);
  }
  // Key frames are few (tens); a binary search over start times.
  int lo = 0, hi = num_frames() - 1;
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (start_times_[mid] <= time) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  *index = lo;
  *alpha = std::fmin(std::fmax((time - start_times_[lo]) / durations_[lo], 0.0), 1.0);
}

double MotionClip::Phase(double time) const {
  double d = duration();
  if (loop_) return time / d - std::floor(time / d);
  return std::fmin(std::fmax(time / d, 0.0), 1.0);
}

Pose MotionClip::Sample(double time) const {
  Pose out;
  SampleInto(time, &out);
  return out;
}

void MotionClip::SampleInto(double time, Pose* out) const {
  int i;
  double alpha, cycles;
  Locate(time, &i, &alpha, &cycles);
  const Pose& a = frames_[i];
  const Pose& b = frames_[i + 1];
  for (int k = 0; k < 3; ++k) {
    out->root_position[k] = (1 - alpha) * a.root_position[k] + alpha * b.root_position[k];
  }
  out->root_rotation = Slerp(a.root_rotation, b.root_rotation, alpha);
  if (cycles != 0) ApplyCycles(cycles, &out->root_position, &out->root_rotation);
  out->joint_rotations.resize(a.joint_rotations.size());
  for (size_t j = 0; j < a.joint_rotations.size(); ++j) {
    out->joint_rotations[j] = Slerp(a.joint_rotations[j], b.joint_rotations[j], alpha);
  }
}

void MotionClip::SampleRootVelocity(double time, Vec3* linear, Vec3* angular) const {
  int i;
  double alpha, cycles;
  Locate(time, &i, &alpha, &cycles);
  if (!loop_ && (time < 0 || time > duration())) {  // holding a pose
    *linear = {0, 0, 0};
    *angular = {0, 0, 0};
    return;
  }
  const Pose& a = frames_[i];
  const Pose& b = frames_[i + 1];
  double dt = durations_[i];
  for (int k = 0; k < 3; ++k) (*linear)[k] = (b.root_position[k] - a.root_position[k]) / dt;
  if (cycle_yaw_ != 0 && cycles != 0) {  // the velocity turns with the root
    const double c = std::cos(cycles * cycle_yaw_), s = std::sin(cycles * cycle_yaw_);
    const double x = (*linear)[0], y = (*linear)[1];
    (*linear)[0] = c * x - s * y;
    (*linear)[1] = s * x + c * y;
  }
  // Slerp turns at a constant rate about a fixed axis, so the velocity in the current frame
  // equals the one in the key frame's frame.
  *angular = AngularVelocity(a.root_rotation, b.root_rotation, dt);
}

PoseVelocity MotionClip::SampleVelocity(double time) const {
  PoseVelocity out;
  SampleRootVelocity(time, &out.root_linear, &out.root_angular);
  out.joint_angular.assign(frames_[0].joint_rotations.size(), {0, 0, 0});
  if (!loop_ && (time < 0 || time > duration())) return out;  // holding a pose
  int i;
  double alpha, cycles;
  Locate(time, &i, &alpha, &cycles);
  const Pose& a = frames_[i];
  const Pose& b = frames_[i + 1];
  for (size_t j = 0; j < a.joint_rotations.size(); ++j) {
    out.joint_angular[j] =
        AngularVelocity(a.joint_rotations[j], b.joint_rotations[j], durations_[i]);
  }
  return out;
}

}  // namespace ragdoll::character
