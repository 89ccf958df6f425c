// The project's own reference clips, authored procedurally on the character's skeleton:
// stand, arms, squat and walk. assets/motions/*.json are these clips as written by
// `ragdoll-author-clips`; a test checks the files still match this code.
#pragma once

#include <string>
#include <vector>

#include "actor/sim/character.h"
#include "actor/sim/motion_clip.h"

namespace ragdoll::sim {

struct AuthoredClip {
  MotionClip clip;
  std::string description;
};

// All shipped clips, in the order stand, arms, squat, walk. Leg poses come from two-link inverse
// kinematics so that planted feet stay flat and still on the floor.
std::vector<AuthoredClip> AuthorClips(const Character& character);

}  // namespace ragdoll::sim
