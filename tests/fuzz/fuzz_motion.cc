// libFuzzer target: the motion clip readers (the project's JSON and DeepMimic's files) on
// arbitrary text; a clip that loads is sampled across and beyond its length.
#include <cstddef>
#include <cstdint>
#include <string>

#include "character/motion_io.h"
#include "common/config_section.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    ragdoll::character::MotionClip clip = ragdoll::character::ParseMotion(
        std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
    for (double t : {0.0, 0.37 * clip.duration(), clip.duration(), 2.5 * clip.duration()}) {
      clip.Sample(t);
      clip.SampleVelocity(t);
    }
  } catch (const ragdoll::ConfigError&) {
  }
  return 0;
}
