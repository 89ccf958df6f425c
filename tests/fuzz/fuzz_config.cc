// libFuzzer target: the experiment YAML reader, section by section as every role reads it, on
// arbitrary text. Bad configs must end in ConfigError naming what and where.
#include <cstddef>
#include <cstdint>
#include <string>

#include "character/character.h"
#include "common/config_section.h"
#include "common/endpoints.h"
#include "common/metrics.h"
#include "learner/learner_process.h"
#include "learner/trainer_config.h"
#include "sim/env_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace ragdoll;
  try {
    ConfigSection root = ConfigSection::FromString(
        std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
    try {
      learner::ReadTrainerConfig(root.Section("trainer"));
    } catch (const ConfigError&) {
    }
    try {
      ReadEndpoints(root.Section("broker"));
    } catch (const ConfigError&) {
    }
    try {
      ReadMetricsConfig(root.Section("metrics"));
    } catch (const ConfigError&) {
    }
    try {
      learner::ReadReplicaSettings(root.Section("learner"));
    } catch (const ConfigError&) {
    }
    sim::ReadEnvConfig(root.Section("environment"), character::DefaultCharacterPath());
  } catch (const ConfigError&) {
  }
  return 0;
}
