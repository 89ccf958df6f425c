// Root motion from the feet: a locomotion clip exported "in place" (Mixamo's option, common in
// game asset packs) keeps the hips over the origin while the planted feet slide backward at the
// walking speed. A character imitating it marks time. The root's travel is rebuilt from the
// feet: while a foot bears weight its contact point is taken to be still, so whatever moves it
// is motion the exporter removed from the root, and the root gets it back.
#pragma once

#include <string>

#include "character/character.h"
#include "character/motion_clip.h"

namespace ragdoll::motion {

enum class RootMotion {
  kAuto,  // rebuild when the clip is detected as in place, else leave it untouched
  kFeet,  // always rebuild from the feet
  kKeep,  // never
};

// Parses "auto", "feet" or "keep"; throws std::invalid_argument naming the value otherwise.
RootMotion ParseRootMotion(const std::string& text);

struct RootMotionReport {
  // What the clip shows: the root's net horizontal speed over the clip, and, over the intervals
  // where some foot bears weight (`support_fraction` of the clip's time), the mean velocity of
  // the planted contact points and how consistently they move that way (|mean| / mean |v|: 1
  // when every planted foot slides the same way, near 0 for feet pivoting in a turn on the spot).
  double root_speed = 0;  // m/s
  character::Vec3 slide_velocity = {0, 0, 0};
  double slide_coherence = 0;
  double support_fraction = 0;
  bool in_place = false;                     // the detector's verdict
  bool reconstructed = false;                // the root was rebuilt (auto and in place, or feet)
  character::Vec3 added_travel = {0, 0, 0};  // m: horizontal travel given to the root over the clip
  // One line for `motion import`.
  std::string Summary() const;
};

// Detection thresholds. A clip is in place when the planted feet slide at `min_slide_speed` or
// more, coherently, for a good part of the clip, while the root travels net less than
// `max_root_ratio` of that speed.
struct RootMotionOptions {
  double plant_height = 0.025;    // m above the foot's own lowest height: bearing weight
  double min_slide_speed = 0.25;  // m/s
  double min_coherence = 0.7;
  double min_support = 0.2;  // of the clip's time (a run at 30 frames/s: 0.3)
  double max_root_ratio = 0.25;
};

// The clip with its root's horizontal travel rebuilt (or `clip` unchanged: see `mode`); heights,
// rotations and timing are kept, so a turn in place stays a turn. `report` (optional) says what
// was found and done.
character::MotionClip ReconstructRootMotion(const character::MotionClip& clip,
                                            const character::Character& character, RootMotion mode,
                                            RootMotionReport* report = nullptr,
                                            const RootMotionOptions& options = {});

}  // namespace ragdoll::motion
