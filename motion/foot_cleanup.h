// Foot clean-up of an imported clip (`ragdoll motion import --fix-feet`): the frames where a
// foot is planted are found from the clip itself, and in them the leg is re-solved (leg IK,
// motion/leg_ik.h) so that the foot's lowest point is on the floor and the ankle holds still,
// the foot keeping its own rotation (`--feet floor` levels it); the correction fades in and out
// around each plant. Where a leg cannot reach, the pelvis comes down (smoothly) until it can.
// Everything above the legs is left as it was.
//
// A retarget keeps each segment's rotation, so a capture whose proportions differ from the
// character's leaves feet floating a few centimetres above the floor or sliding while they bear
// weight; a simulated character imitating that clip has no such freedom.
#pragma once

#include <array>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::motion {

struct FootCleanupOptions {
  // A foot is planted in a frame when its lowest point is within `plant_height` of the lowest
  // height that foot takes in the clip (each foot its own: a foot the retarget left floating
  // is planted as well) and moves horizontally slower than `plant_speed`.
  double plant_height = 0.03;  // m
  double plant_speed = 0.4;    // m/s
  double min_plant = 0.1;      // s: briefer plants are left alone
  double blend = 0.15;         // s: the correction fades in before a plant and out after it
};

struct FootCleanupReport {
  // Per foot, right then left.
  std::array<int, 2> plants = {0, 0};               // plants fixed
  std::array<double, 2> planted_fraction = {0, 0};  // of the frames
  std::array<double, 2> float_height = {0, 0};      // m: the foot's lowest height before
  double max_correction = 0;                        // m: the largest move of an ankle
  double max_drop = 0;    // m: the most the pelvis came down for the legs to reach
  double max_miss = 0;    // m: the largest distance a solved ankle stays from its target
  int missed_frames = 0;  // frames where some foot stays more than 1 cm from its target

  // Whether the clip needed it: some ankle moved more than `kNeededCorrection`. Below that the
  // feet already stand and hold still (a clip made for the character, a careful capture), and
  // `motion import` keeps the clip exactly as it came.
  static constexpr double kNeededCorrection = 0.01;  // m
  bool Needed() const { return max_correction > kNeededCorrection; }
};

// The clip with its feet fixed; `report` (optional) says what was done. The clip's floor is
// z = 0. Throws std::invalid_argument for options that are not positive.
character::MotionClip FixFeet(const character::MotionClip& clip,
                              const character::Character& character,
                              const FootCleanupOptions& options,
                              FootCleanupReport* report = nullptr);

}  // namespace ragdoll::motion
