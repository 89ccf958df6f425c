// A reference animation clip of the humanoid3d skeleton: timed key frames of the root's position
// and rotation and every joint's local rotation, sampled at any time with interpolation.
#pragma once

#include <string>
#include <vector>

#include "character/rotation.h"

namespace ragdoll::character {

// A kinematic pose. Z-up world, metres; rotations are unit quaternions (w, x, y, z).
struct Pose {
  Vec3 root_position = {0, 0, 0};
  Quat root_rotation = kIdentityQuat;
  // One per joint of Humanoid3dJoints(), each relative to its parent body.
  std::vector<Quat> joint_rotations;
};

// The time derivative of a clip's pose.
struct PoseVelocity {
  Vec3 root_linear = {0, 0, 0};     // world frame, m/s
  Vec3 root_angular = {0, 0, 0};    // root's own frame, rad/s (MuJoCo's free-joint convention)
  std::vector<Vec3> joint_angular;  // each joint's own (child) frame, rad/s
};

// How a looping clip's root carries on from one cycle into the next.
enum class CycleTransform {
  // By the horizontal rigid motion (a turn about +z and a translation in x, y) that takes the
  // first frame's root position and heading onto the last frame's: a clip that turns in place
  // keeps turning.
  kPlanar,
  // By the horizontal translation only, the heading starting over each cycle: DeepMimic's "wrap"
  // loop, kept for its motion files, whose first and last headings differ by a few degrees.
  kTranslation,
};

class MotionClip {
 public:
  // `frame_durations[i]` is the time from frame i to frame i + 1 (the last entry is unused).
  // A looping clip's last frame closes the cycle: it is the first pose, moved by however far
  // the root travels and turns in one cycle. Throws std::invalid_argument naming the frame and
  // field on fewer than two frames, non-positive or non-finite durations, wrong joint counts, or
  // a rotation that is not finite or whose norm is outside [0.5, 1.5]. Other rotations are
  // normalised (motion files in the wild carry norms off by 15 %).
  MotionClip(std::string name, bool loop, std::vector<double> frame_durations,
             std::vector<Pose> frames, CycleTransform cycle = CycleTransform::kPlanar);

  const std::string& name() const { return name_; }
  bool loop() const { return loop_; }
  // Length of one pass (one cycle for a looping clip), seconds.
  double duration() const { return start_times_.back(); }
  int num_frames() const { return static_cast<int>(frames_.size()); }
  const Pose& frame(int i) const { return frames_[i]; }
  double frame_time(int i) const { return start_times_[i]; }
  double frame_duration(int i) const { return durations_[i]; }
  // Rotations whose norm was off by more than file rounding (1e-3) and were normalised, and the
  // largest deviation |norm - 1| of any rotation in the clip.
  int renormalized_rotations() const { return renormalized_rotations_; }
  double max_norm_deviation() const { return max_norm_deviation_; }
  CycleTransform cycle_transform() const { return cycle_transform_; }
  // Horizontal root displacement over one cycle, last frame less first (zero for a clip that
  // does not loop).
  const Vec3& cycle_displacement() const { return cycle_displacement_; }
  // The turn of the root's heading (YawOf) over one cycle, last frame less first, radians in
  // [-pi, pi] (zero for a clip that does not loop, and for CycleTransform::kTranslation).
  double cycle_yaw() const { return cycle_yaw_; }

  // Phase in [0, 1] of `time` within the current cycle (clamped for a clip that does not loop).
  double Phase(double time) const;
  // The pose at `time` seconds: positions interpolated linearly, rotations by slerp. A looping
  // clip repeats forever: k cycles on (k < 0: before), its root is moved by the cycle transform
  // T applied k times, T the horizontal rigid motion taking the first frame's root onto the
  // last's (with cycle_yaw() zero: a translation by k cycle_displacement()). Other clips hold
  // their first or last pose outside [0, duration()].
  Pose Sample(double time) const;
  // The same, reusing `out`'s storage (no allocation once it has the right size).
  void SampleInto(double time, Pose* out) const;
  // The velocity at `time`: the derivative of Sample() (constant between two key frames; the
  // root's linear velocity turned with the cycles, its angular velocity in its own frame).
  PoseVelocity SampleVelocity(double time) const;
  // Only the root's part of SampleVelocity (no allocation): what the environment needs each step.
  void SampleRootVelocity(double time, Vec3* linear, Vec3* angular) const;

 private:
  // Key frame index i and blend alpha in [0, 1) for `time`, plus whole cycles elapsed.
  void Locate(double time, int* index, double* alpha, double* cycles) const;
  // Moves a root position and rotation sampled within the first cycle on by `cycles` cycles.
  void ApplyCycles(double cycles, Vec3* position, Quat* rotation) const;
  // `q` scaled to unit length, counted; throws for a degenerate one, naming frame and field.
  Quat Renormalize(const Quat& q, int frame, const std::string& field);

  std::string name_;
  bool loop_;
  std::vector<double> durations_;
  std::vector<double> start_times_;
  std::vector<Pose> frames_;
  CycleTransform cycle_transform_;
  Vec3 cycle_displacement_ = {0, 0, 0};
  double cycle_yaw_ = 0;
  Vec3 cycle_pivot_ = {0, 0, 0};  // the first frame's root position: T turns about it
  int renormalized_rotations_ = 0;
  double max_norm_deviation_ = 0;
};

}  // namespace ragdoll::character
