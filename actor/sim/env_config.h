// Configuration of the imitation environment (the `environment:` section of an experiment).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "actor/sim/imitation_reward.h"

namespace ragdoll {
class ConfigSection;
}

namespace ragdoll::sim {

enum class ActionMode {
  kAbsolute,  // action in [-1, 1] spans each hinge's range: the PD target itself
  kOffset,    // action in [-1, 1] offsets the reference pose by up to offset_scale * half range
};

// What of the reference root follows the character at the start of each cycle of a looping clip
// (DeepMimic's SyncKinCharNewCycle). Without it the reference keeps its own path: any drift
// accumulates over the episode, and the root and centre-of-mass terms then score an offset the
// policy cannot observe.
enum class ReferenceSync {
  kNone,                // the reference walks its own path from the episode's start
  kPosition,            // its horizontal root position moves to the character's (DeepMimic's walk)
  kPositionAndHeading,  // and it turns to the character's heading
};

struct EnvConfig {
  std::string character;          // MJCF file
  std::string motion;             // reference clip (project format or DeepMimic motion file)
  double control_frequency = 30;  // policy decisions per second
  int substeps = 20;              // physics steps per decision (timestep = 1 / (f * substeps))
  int max_episode_steps = 300;    // truncation: episode length in decisions
  ActionMode action_mode = ActionMode::kAbsolute;
  double offset_scale = 0.5;
  bool random_start = true;  // reference state initialisation at a uniformly random phase
  double start_phase = 0.0;  // the phase in [0, 1) used when random_start is false
  // Bodies that may touch the ground; any other contact ends the episode (a fall).
  // `allowed_contacts: auto` (the default): the feet and every body the reference clip puts on
  // the floor (ClipGroundContacts), resolved when the environment is built.
  bool contacts_from_clip = true;
  std::vector<std::string> allowed_contacts;  // the explicit list, when not from the clip
  // The episode also ends when the root is further than this from the reference root, m.
  double max_root_distance = 1.0;
  ReferenceSync reference_sync = ReferenceSync::kPositionAndHeading;  // `sync_reference`
  // Relative importance of each joint in the rotation and velocity terms (DeepMimic's humanoid3d
  // values; a joint left out weighs 0).
  std::map<std::string, double> joint_weights = {
      {"chest", 0.5},       {"neck", 0.3},           {"right_hip", 0.5},     {"right_knee", 0.3},
      {"right_ankle", 0.2}, {"right_shoulder", 0.3}, {"right_elbow", 0.2},   {"left_hip", 0.5},
      {"left_knee", 0.3},   {"left_ankle", 0.2},     {"left_shoulder", 0.3}, {"left_elbow", 0.2}};
  RewardConfig reward;

  double control_dt() const { return 1.0 / control_frequency; }
  double physics_dt() const { return 1.0 / (control_frequency * substeps); }
};

// Reads and validates the section; throws ConfigError naming file, key and value.
// `default_character` is used when the section names none.
EnvConfig ReadEnvConfig(const ConfigSection& section, const std::string& default_character);

}  // namespace ragdoll::sim
