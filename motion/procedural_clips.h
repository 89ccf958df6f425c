// The project's own reference clips, authored procedurally on the character's skeleton: stand,
// arms, squat and walk, and a steerable character's motion set (walk_backward, strafe_left,
// turn_left, walk_start, walk_stop). assets/motions/*.json are these clips as written by
// `ragdoll-author-clips`; a test checks the files still match this code.
#pragma once

#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::motion {

struct AuthoredClip {
  character::MotionClip clip;
  std::string description;
};

// All shipped clips, in this order:
//   stand          standing still, knees slightly bent (2 s loop, 30 fps)
//   arms           arms rising sideways in turn, legs still (4 s loop, 30 fps)
//   squat          down to 90 degrees of knee flexion and up (4 s loop, 30 fps)
//   walk           0.9 m/s, 0.9 m strides, heel rise onto the toes (1 s cycle, 60 fps)
//   walk_backward  0.5 m/s backward, 0.5 m strides, flat-footed (1 s cycle, 60 fps)
//   strafe_left    0.4 m/s to the left facing forward, side steps (0.8 s cycle, 60 fps)
//   turn_left      turning counter-clockwise on the spot at 60 deg/s (1.5 s cycle of 90
//                  degrees, 60 fps; the clip loops by turning, MotionClip::cycle_yaw())
//   walk_start     stand's pose to the walk's at phase 0.6, 0.9 m/s (1.2 s, not looping)
//   walk_stop      the walk's pose at phase 0.6 to stand's (1.5 s, not looping)
// Leg poses come from inverse kinematics (two-link in the sagittal plane for the first four,
// SolveLegIk for the others) so that planted feet stay flat and still on the floor. Throws
// std::logic_error if a foot of the gaits could not be placed (a change that puts it out of the
// leg's reach).
std::vector<AuthoredClip> AuthorClips(const character::Character& character);

}  // namespace ragdoll::motion
