// Configuration of the imitation environment (the `environment:` section of an experiment).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "sim/imitation_reward.h"

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

// What a steerable character is told to do, in the frame of its desired heading: walk at this
// planar velocity and turn at this rate. The desired heading turns with `turn`.
struct Command {
  double forward = 0;  // m/s along the desired heading
  double left = 0;     // m/s to its left
  double turn = 0;     // rad/s, counter-clockwise seen from above
};

// One clip of a steering motion set (an item of `steering.motions`).
struct MotionSetItem {
  std::string name;     // how commands, scripts and transitions name it; default: the file's stem
  std::string motion;   // clip file (any format LoadMotion reads)
  bool mirror = false;  // left and right swapped: strafe right from strafe left
  // The command the clip demonstrates; measured from the clip (its mean velocity in its own
  // heading frame and its mean turn rate) unless given.
  bool command_from_clip = true;
  Command command;
  // A transition clip (one that does not loop) plays when the command changes from the item
  // named `from` to the one named `to`, and hands over to `to` when it ends. Both or neither.
  std::string from, to;
  // How often training draws this clip's command, relative to the others (`weight`, default 1).
  double weight = 1.0;
  bool transition() const { return !to.empty(); }
};

// The steering task (the `steering:` section): one policy follows commands, imitating the
// motion-set clip that demonstrates the current command, rewarded also for tracking the
// commanded velocity and heading (DeepMimic's imitation + task reward).
struct SteeringConfig {
  std::vector<MotionSetItem> motions;  // empty: no steering; the single `motion` is imitated
  // During training the command changes at uniformly random intervals in [min, max] seconds,
  // and at every reset.
  double command_interval_min = 2.0;
  double command_interval_max = 5.0;
  // Task reward: velocity_weight * exp(-velocity_scale |v - v*|^2) +
  // heading_weight * exp(-heading_scale (heading - desired)^2), v the travel velocity averaged
  // over velocity_window seconds (one step of a walk), in m/s and radians.
  double velocity_weight = 0.3;
  double heading_weight = 0.2;
  double velocity_scale = 4.0;
  double heading_scale = 2.0;
  double velocity_window = 0.5;
  // Catch steps (`catch_steps: {above, seconds}`; absent: none): told to stand, a character whose
  // pelvis moves faster than `above` m/s (a push) imitates for `seconds` the clip of the set whose
  // travel is nearest its own, then stands again (through the set's transition): standing still
  // has no step to imitate, and a push of more than about 0.5 m/s needs one.
  double catch_above = 0;  // m/s; 0: off
  double catch_seconds = 0;
  bool enabled() const { return !motions.empty(); }
  double MaxReward() const { return enabled() ? velocity_weight + heading_weight : 0.0; }
};

// Random pushes while training (the `perturbations:` section): at random intervals a random body
// is pushed horizontally in a random direction for a random duration, with an impulse drawn from
// [level / 2, level]. The level is a curriculum per environment: after every `window` pushes it
// rises by `step` when the character survived at least `raise_above` of them (no fall within
// `judge` seconds of the push's start) and falls by `step` when fewer than `lower_below`, within
// [start, max]. Evaluation, play and export run a policy without them.
struct PerturbationConfig {
  std::vector<std::string> bodies;                // pushed at random; empty: no pushes
  double interval_min = 1.0, interval_max = 3.0;  // s between pushes
  double duration_min = 0.1, duration_max = 0.2;  // s a push lasts
  double start = 20, max = 150, step = 5;         // the level, N s
  int window = 10;
  double raise_above = 0.8, lower_below = 0.5;
  double judge = 2.0;  // s
  // A level for each situation (pushed body, direction in quarters of the character's heading,
  // told to stand still or not), and the quarter drawn by its recent share of falls: the hard
  // situations are pushed at their own edge and more often, not at a level the easy ones set.
  bool per_situation = false;
  bool enabled() const { return !bodies.empty(); }
};

// Falling and getting up (the `recovery:` section): a fall no longer ends an episode. When the
// state shows one (a body the base clips keep off the floor touches it), the reference becomes
// the get-up clip for how the character lies, entered at its closest key frame; once that clip
// has played and the character stands, the reference hands back to the base clip. Episodes also
// start fallen (a settled, simulated fall) or at a random frame of a get-up clip.
struct RecoveryConfig {
  std::string face_down, face_up;  // get-up clips (DeepMimic's getup_facedown / getup_faceup)
  double start_fallen = 0.25;      // share of episodes that start from a settled fall
  double start_getting_up = 0.25;  // share that start at a random time of a get-up clip
  // The imitation reward while getting up counts this much, so that falling costs.
  double get_up_reward_scale = 0.5;
  // Still getting up this long after a fall (or a fallen start), s: the episode ends as a fall.
  double give_up_after = 8.0;
  // While getting up, a body the get-up clip keeps more than early_termination_height (m) off
  // the floor in all its frames touching it, or the clip's end reached without standing, ends
  // the episode as a fall: DeepMimic's early termination, applied to the get-up too.
  // On by default, at the 2 cm of `allowed_contacts: auto`: without them get-ups were not learned
  // (docs/training-experiments.md, A-I).
  bool early_termination = true;
  double early_termination_height = 0.02;
  // Steering: after a get-up the character is told to stand this long (s) before the command
  // leads again; a get-up ends off balance, and starting to walk from there fell again.
  double stand_after_get_up = 0.0;
  bool enabled() const { return !face_down.empty(); }
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
  // the floor (ClipGroundContacts), filled in once (ResolveAllowedContacts) by the first to load
  // the clips: the run's start-up, a rollout worker, or an environment built on its own.
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
  SteeringConfig steering;
  PerturbationConfig perturbations;
  RecoveryConfig recovery;

  double control_dt() const { return 1.0 / control_frequency; }
  double physics_dt() const { return 1.0 / (control_frequency * substeps); }
};

// Reads and validates the section; throws ConfigError naming file, key and value.
// `default_character` is used when the section names none.
EnvConfig ReadEnvConfig(const ConfigSection& section, const std::string& default_character);

}  // namespace ragdoll::sim
