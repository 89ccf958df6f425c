// What kind of clip an import gave, for choosing how to train it (`ragdoll train --motion`):
// whether it closes a loop, and whether it is locomotion, a loop in place, a one-shot action, or
// a clip that puts more than the feet on the floor.
#pragma once

#include <string>

#include "character/motion_clip.h"
#include "motion/clip_report.h"

namespace ragdoll::motion {

// Whether the clip's last frame is its first pose again, up to where the root went and how it
// turned: its joints within `kLoopMeanDegrees` on average and each within `kLoopJointDegrees`
// (DeepMimic's captured walk closes its cycle to 7.8 on average, 28.5 at a shoulder; the
// shipped walk_start and walk_stop, which do not loop, are 12.6 and 33.6 apart), the root's
// height within `kLoopHeight` and its tilt within `kLoopMeanDegrees`. `why` (optional) names the
// figure that decided.
constexpr double kLoopMeanDegrees = 10;
constexpr double kLoopJointDegrees = 30;
constexpr double kLoopHeight = 0.04;  // m
bool ClosesALoop(const character::MotionClip& clip, std::string* why = nullptr);

// The clip marked as looping (its frames unchanged).
character::MotionClip AsLoop(const character::MotionClip& clip);

enum class ClipKind {
  kLocomotion,   // a loop whose root travels or turns each cycle (walks, runs, strafes, turns)
  kInPlace,      // a loop that stays where it is (standing, dancing on the spot, exercises)
  kAction,       // plays once (a punch, a kick, a jump)
  kContactRich,  // more than the feet on the floor (get-ups, crawls, rolls, kneeling)
};

struct ClipKindChoice {
  ClipKind kind;
  std::string name;    // "looping locomotion", "loop in place", "one-shot action", "contact-rich"
  std::string config;  // the shipped config it trains with, a file name in configs/
  std::string reason;  // the figures that decided, for the user
};

// Thresholds: locomotion travels at least `kLocomotionSpeed` or turns at least
// `kLocomotionTurn` per cycle; a clip is contact-rich when a body other than the feet touches
// the floor in at least `kContactShare` of its frames.
constexpr double kLocomotionSpeed = 0.15;  // m/s
constexpr double kLocomotionTurn = 0.2;    // rad per cycle
constexpr double kContactShare = 0.1;
ClipKindChoice ClassifyClip(const character::MotionClip& clip, const ClipReport& report);

}  // namespace ragdoll::motion
