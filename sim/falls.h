// Fallen states and the tests of a character's posture that recovery is measured by: a character
// thrown down as a ragdoll (its joints only damped) and left until it lies still; whether it lies
// face down, face up or on a side; whether it stands.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::sim {

enum class Posture { kStanding, kFaceDown, kFaceUp, kSide, kOther };
const char* PostureName(Posture posture);

// How a character lies or stands, from its root's orientation and height: standing when the trunk
// is within 30 degrees of upright and the root above `stand_height` (metres); lying when the
// trunk is within 45 degrees of horizontal, face down or up by where its front points.
Posture PostureOf(const character::Character& character, const mjData& d, double stand_height);
// The stand height recovery is judged by: 0.8 of the root's height in the clip's first frame.
double StandHeight(const character::MotionClip& clip);

struct FallenState {
  std::vector<double> qpos, qvel;
  Posture posture = Posture::kOther;
  double seconds = 0;  // simulated until still
};

// The clip's pose at a random time, laid on its front, its back or a side (one of four, at
// random, each turned by up to 20 degrees more and facing a random way), released 0.25 m above
// the floor and simulated limp (every actuator's target follows its joint, so the joints are only
// damped) until no joint moves faster than 0.3 rad/s for 0.2 s (contacts keep some twitching), or
// for at most 4 s.
FallenState SettledFall(const character::Character& character, const character::MotionClip& clip,
                        std::mt19937_64& rng);

}  // namespace ragdoll::sim
