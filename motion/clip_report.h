// What `ragdoll motion inspect` says about a clip on the character: timing, root travel, an
// estimate of when each foot is on the floor, and the frames a simulated character could not
// reproduce (geometry below the floor, planted feet sliding, joints beyond their limits).
#pragma once

#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::motion {

struct ClipIssue {
  int frame = 0;
  double time = 0;
  std::string kind;    // "penetration", "foot_sliding", "joint_limit"
  std::string detail;  // e.g. "left_ankle 3.1 cm below the floor"
};

struct ClipReport {
  std::string name;
  int frames = 0;
  double duration = 0;  // seconds (one cycle for a looping clip)
  double fps = 0;       // frames per second (mean)
  bool loop = false;
  std::vector<std::string> joints;
  character::Vec3 root_travel = {0, 0, 0};         // last frame's root position minus the first's
  double root_path_length = 0;                     // horizontal distance the root covers, metres
  character::Vec3 cycle_displacement = {0, 0, 0};  // a looping clip's root displacement per cycle
  double cycle_yaw = 0;  // and its turn per cycle, radians (counter-clockwise)
  double root_height_min = 0, root_height_max = 0;
  double contact_right = 0, contact_left = 0;  // fraction of frames the foot is on the floor
  // Every body whose geometry comes within 2 cm of the floor in some key frame, in skeleton
  // order, with the fraction of frames it does: where the clip itself touches the ground.
  std::vector<std::pair<std::string, double>> ground_contacts;
  // Rotations the reader normalised (norm off by more than 1e-3) and the largest |norm - 1|.
  int renormalized_rotations = 0;
  double max_norm_deviation = 0;
  double lowest_point = 0;  // lowest geometry over the clip, metres
  std::vector<ClipIssue> issues;

  int Count(const std::string& kind) const;
  std::string ToText() const;  // a plain summary, one line per figure, up to 5 frames per issue
  std::string ToJson() const;
};

// Thresholds: geometry more than 1 cm below the floor; a foot is in contact when within 2 cm
// of the floor, and slides when its lowest corner stays within 5 mm of the floor in two
// consecutive frames yet moves faster than 0.3 m/s; a hinge angle more than 0.05 rad beyond its
// range.
ClipReport InspectClip(const character::MotionClip& clip, const character::Character& character);

}  // namespace ragdoll::motion
