// The character's soles as the motion pipeline sees them: the corners of each foot's box geoms,
// shared by foot clean-up and root-motion reconstruction.
#pragma once

#include <mujoco/mujoco.h>

#include <vector>

#include "character/rotation.h"

namespace ragdoll::motion {

// The corners of `body`'s box geoms, in the body's frame (empty when it has none).
std::vector<character::Vec3> FootCorners(const mjModel* m, int body);

}  // namespace ragdoll::motion
