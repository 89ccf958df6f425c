// A clip turned about the vertical through the origin: the same motion facing another way, for
// tests of what depends on the character's heading.
#pragma once

#include <string>
#include <vector>

#include "actor/sim/motion_clip.h"
#include "actor/sim/rotation.h"

namespace ragdoll::sim {

inline MotionClip TurnedClip(const MotionClip& clip, double yaw, const std::string& name) {
  const Quat turn = AxisAngle({0, 0, 1}, yaw);
  std::vector<Pose> frames;
  std::vector<double> durations;
  for (int i = 0; i < clip.num_frames(); ++i) {
    Pose pose = clip.frame(i);
    pose.root_position = Rotate(turn, pose.root_position);
    pose.root_rotation = Multiply(turn, pose.root_rotation);
    frames.push_back(pose);
    durations.push_back(clip.frame_duration(i));
  }
  return MotionClip(name, clip.loop(), durations, frames);
}

}  // namespace ragdoll::sim
