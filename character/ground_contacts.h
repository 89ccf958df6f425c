// Where a clip puts the character on the floor: `allowed_contacts: auto` lets those bodies touch
// the ground without ending the episode (a crawl's hands and knees, a walk's feet).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::character {

// A body touches the floor when some geom of it comes within this height of it, in metres.
inline constexpr double kGroundContactHeight = 0.02;

// Every body whose geometry comes within `height` of the floor in some key frame of `clip`, in
// skeleton order, with the fraction of frames it does.
std::vector<std::pair<std::string, double>> GroundContactFractions(
    const MotionClip& clip, const Character& character, double height = kGroundContactHeight);

// The bodies that may touch the ground while imitating `clip` (`allowed_contacts: auto`): the
// feet, and every body the clip itself puts on the floor (GroundContactFractions).
std::vector<std::string> ClipGroundContacts(const MotionClip& clip, const Character& character);

// Sets `on[body]` to whether it is in contact with the floor (body 0, the world) in `d`'s current
// contacts; `on` is resized to the model's bodies.
void BodiesOnGround(const mjModel* m, const mjData& d, std::vector<char>* on);

// Whether a body for which `may_touch[body]` is 0 is in contact with the floor (body 0, the world)
// in `d`'s current contacts: a fall, by the episode's rule or recovery's.
bool TouchesGroundOutside(const mjModel* m, const mjData& d, const std::vector<char>& may_touch);

}  // namespace ragdoll::character
