// Inverse kinematics of the character's legs: the hip, knee and ankle hinge angles that put a
// foot where it should be, for whatever pose the pelvis is in. Clip authoring uses it to plant
// feet flat on the floor; it serves as well to fix the feet of imported clips.
#pragma once

#include <mujoco/mujoco.h>

#include <string>

#include "character/character.h"
#include "character/rotation.h"

namespace ragdoll::motion {

// How far the solved foot is from its target.
struct LegIkResult {
  double position_error = 0;  // metres, ankle joint to target position
  double angle_error = 0;     // radians, foot rotation to target rotation
  int iterations = 0;
};

// Sets the seven hinges of one leg (`side` "right" or "left": <side>_hip's three, <side>_knee,
// <side>_ankle's three) in `qpos` (model()->nq entries) so that the body `<side>_ankle` has its
// origin, the ankle joint, at `position` and its rotation equal to `rotation`, both in the world
// frame. The root and every other joint keep their values in `qpos`: set the pelvis first.
//
// Damped least squares on the body's Jacobian (mj_jacBody), each step solved within the hinge
// ranges and taken only when it brings the foot closer. A leg has one hinge more than a foot
// pose needs (the knee may swing about the hip-ankle line); that freedom is drawn toward the
// angles `qpos` holds on entry, so a good starting pose also picks the solution. When the
// iteration stops short (a joint limit in the way), it starts over from a few bent-knee poses
// and keeps the best. The hinges always end within their ranges; a target the leg cannot reach
// returns the closest pose found and its error. `scratch` is a mjData of the character's model
// the solver overwrites (nullptr: one is made for the call).
// Throws std::invalid_argument for another side.
LegIkResult SolveLegIk(const character::Character& character, const std::string& side,
                       const character::Vec3& position, const character::Quat& rotation,
                       double* qpos, mjData* scratch = nullptr);

}  // namespace ragdoll::motion
