// libFuzzer target: the BVH parser on arbitrary text. Bad files must end in ConfigError.
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/config_section.h"
#include "motion/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    ragdoll::motion::ParseBvh(std::string(reinterpret_cast<const char*>(data), size), "fuzz.bvh");
  } catch (const ragdoll::ConfigError&) {
  }
  return 0;
}
