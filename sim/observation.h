// What the policy sees: the character's body states in its heading frame, and the clip phase.
#pragma once

#include <mujoco/mujoco.h>

#include <string>
#include <vector>

namespace ragdoll::character {
class Character;
}  // namespace ragdoll::character

namespace ragdoll::sim {

// Floats per observation for `character`.
int ObservationSize(const character::Character& character);
// A name for each entry, e.g. "right_knee.pos.x", "root.height", "phase.sin".
std::vector<std::string> ObservationNames(const character::Character& character);

// Writes the observation of `data` (positions and velocities up to date, as after mj_forward or
// mj_step1) to `out`:
//   root: height, rotation (6: the first two columns of its matrix), linear and angular velocity;
//   every other body: position relative to the root, rotation (6), linear and angular velocity;
//   phase in [0, 1] and its sine and cosine (continuous across a loop).
// Everything except the height is expressed in the heading frame: rotated about the vertical so
// that the root faces +x, which makes the policy independent of where the character walks.
void BuildObservation(const character::Character& character, const mjData& data, double phase,
                      float* out);

}  // namespace ragdoll::sim
