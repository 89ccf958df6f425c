// A clip turned about the vertical through the origin: the same motion facing another way, for
// tests of what depends on the character's heading.
#pragma once

#include <string>
#include <vector>

#include "character/motion_clip.h"
#include "character/rotation.h"

namespace ragdoll::sim {

inline character::MotionClip TurnedClip(const character::MotionClip& clip, double yaw,
                                        const std::string& name) {
  const character::Quat turn = character::AxisAngle({0, 0, 1}, yaw);
  std::vector<character::Pose> frames;
  std::vector<double> durations;
  for (int i = 0; i < clip.num_frames(); ++i) {
    character::Pose pose = clip.frame(i);
    pose.root_position = character::Rotate(turn, pose.root_position);
    pose.root_rotation = character::Multiply(turn, pose.root_rotation);
    frames.push_back(pose);
    durations.push_back(clip.frame_duration(i));
  }
  return character::MotionClip(name, clip.loop(), durations, frames);
}

}  // namespace ragdoll::sim
