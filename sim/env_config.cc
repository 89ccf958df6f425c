#include "sim/env_config.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "character/skeleton.h"
#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

double Positive(const ConfigSection& s, const std::string& key, double fallback) {
  double v = s.Get<double>(key, fallback);
  if (!std::isfinite(v) || v <= 0)
    s.Fail(key, "must be a positive number, got " + std::to_string(v));
  return v;
}

double NonNegative(const ConfigSection& s, const std::string& key, double fallback) {
  double v = s.Get<double>(key, fallback);
  if (!std::isfinite(v) || v < 0) s.Fail(key, "must be zero or more, got " + std::to_string(v));
  return v;
}

std::string Stem(const std::string& path) { return std::filesystem::path(path).stem().string(); }

// An entry's own command, given in the file instead of measured from its clip.
void ReadItemCommand(const ConfigSection& i, MotionSetItem* item) {
  ConfigSection command = i.Section("command");
  item->command_from_clip = false;
  item->command.forward = command.Get<double>("forward", 0.0);
  item->command.left = command.Get<double>("left", 0.0);
  item->command.turn = command.Get<double>("turn", 0.0) * M_PI / 180;  // deg/s in the file
  for (double v : {item->command.forward, item->command.left, item->command.turn}) {
    if (!std::isfinite(v)) i.Fail("command", "must hold finite numbers");
  }
  command.Finish();
}

// One entry of steering.motions; `names` holds the names of the entries before it.
MotionSetItem ReadMotionSetItem(const ConfigSection& i, std::set<std::string>* names) {
  MotionSetItem item;
  item.motion = i.GetPath("motion", "");
  if (item.motion.empty()) i.Fail("motion", "required: the clip file");
  item.mirror = i.Get<bool>("mirror", false);
  item.name = i.Get<std::string>("name", Stem(item.motion) + (item.mirror ? "_mirrored" : ""));
  if (!names->insert(item.name).second) {
    i.Fail("name", "'" + item.name + "' names two clips of the set; give each its own `name`");
  }
  if (i.Has("command")) ReadItemCommand(i, &item);
  item.from = i.Get<std::string>("from", "");
  item.to = i.Get<std::string>("to", "");
  if (item.from.empty() != item.to.empty()) {
    i.Fail(item.from.empty() ? "from" : "to",
           "a transition needs both `from` and `to` (the clips it leads between)");
  }
  if (item.transition() && !item.command_from_clip) {
    i.Fail("command", "a transition's command is its `to` clip's");
  }
  if (i.Has("weight")) {
    if (item.transition()) i.Fail("weight", "a transition is never drawn as a command");
    item.weight = i.Get<double>("weight", 1.0);
    if (!std::isfinite(item.weight) || item.weight <= 0) {
      i.Fail("weight", "must be a positive number, got " + std::to_string(item.weight));
    }
  }
  i.Finish();
  return item;
}

// Every transition leads between two clips of the set that are not transitions, and at least
// one clip is a command.
void CheckMotionSet(const ConfigSection& s, const std::vector<MotionSetItem>& motions) {
  int commands = 0;
  for (const MotionSetItem& item : motions) {
    if (!item.transition()) {
      ++commands;
      continue;
    }
    for (const std::string* end : {&item.from, &item.to}) {
      auto it = std::find_if(motions.begin(), motions.end(),
                             [&](const MotionSetItem& m) { return m.name == *end; });
      if (it == motions.end() || it->transition()) {
        s.Fail("motions", "transition '" + item.name + "' names '" + *end +
                              "', which is not a (non-transition) clip of the set");
      }
    }
  }
  if (commands == 0) s.Fail("motions", "needs at least one clip that is not a transition");
}

// The steering task's own settings: command_interval, task and catch_steps.
void ReadSteeringTask(const ConfigSection& s, SteeringConfig* c) {
  ConfigSection interval = s.Section("command_interval");
  c->command_interval_min = Positive(interval, "min", c->command_interval_min);
  c->command_interval_max = Positive(interval, "max", c->command_interval_max);
  if (c->command_interval_max < c->command_interval_min) {
    interval.Fail("max", "must be at least `min`");
  }
  interval.Finish();
  ConfigSection task = s.Section("task");
  c->velocity_weight = NonNegative(task, "velocity_weight", c->velocity_weight);
  c->heading_weight = NonNegative(task, "heading_weight", c->heading_weight);
  c->velocity_scale = NonNegative(task, "velocity_scale", c->velocity_scale);
  c->heading_scale = NonNegative(task, "heading_scale", c->heading_scale);
  c->velocity_window = Positive(task, "velocity_window", c->velocity_window);
  task.Finish();
  if (s.Has("catch_steps")) {
    ConfigSection steps = s.Section("catch_steps");
    c->catch_above = Positive(steps, "above", 0.5);
    c->catch_seconds = Positive(steps, "seconds", 0.7);
    steps.Finish();
  }
}

void ReadSteering(const ConfigSection& parent, SteeringConfig* c) {
  if (!parent.Has("steering")) return;
  ConfigSection s = parent.Section("steering");
  std::vector<ConfigSection> items = s.SectionList("motions");
  if (items.empty()) s.Fail("motions", "required: the clips of the motion set, at least one");
  std::set<std::string> names;
  for (const ConfigSection& i : items) c->motions.push_back(ReadMotionSetItem(i, &names));
  CheckMotionSet(s, c->motions);
  ReadSteeringTask(s, c);
  s.Finish();
}

// A {min, max} pair of positive numbers.
void ReadRange(const ConfigSection& parent, const std::string& key, double* min, double* max) {
  ConfigSection range = parent.Section(key);
  *min = Positive(range, "min", *min);
  *max = Positive(range, "max", *max);
  if (*max < *min) range.Fail("max", "must be at least `min`");
  range.Finish();
}

void ReadPerturbations(const ConfigSection& parent, PerturbationConfig* c) {
  if (!parent.Has("perturbations")) return;
  ConfigSection s = parent.Section("perturbations");
  c->bodies = s.GetStringList("bodies", {"root", "chest", "left_shoulder", "right_shoulder"});
  if (c->bodies.empty()) s.Fail("bodies", "needs at least one body to push");
  ReadRange(s, "interval", &c->interval_min, &c->interval_max);
  ReadRange(s, "duration", &c->duration_min, &c->duration_max);
  ConfigSection impulse = s.Section("impulse");
  c->start = Positive(impulse, "start", c->start);
  c->max = Positive(impulse, "max", c->max);
  c->step = NonNegative(impulse, "step", c->step);
  if (c->max < c->start) impulse.Fail("max", "must be at least `start`");
  impulse.Finish();
  ConfigSection curriculum = s.Section("curriculum");
  c->window = curriculum.Get<int>("window", c->window);
  if (c->window < 1) curriculum.Fail("window", "must be at least 1");
  c->raise_above = NonNegative(curriculum, "raise_above", c->raise_above);
  c->lower_below = NonNegative(curriculum, "lower_below", c->lower_below);
  if (c->raise_above > 1 || c->lower_below > c->raise_above) {
    curriculum.Fail("lower_below", "needs 0 <= lower_below <= raise_above <= 1");
  }
  c->judge = Positive(curriculum, "judge", c->judge);
  c->per_situation = curriculum.Get<bool>("per_situation", c->per_situation);
  curriculum.Finish();
  s.Finish();
}

void ReadRecovery(const ConfigSection& parent, RecoveryConfig* c) {
  if (!parent.Has("recovery")) return;
  ConfigSection s = parent.Section("recovery");
  c->face_down = s.GetPath("face_down", "");
  c->face_up = s.GetPath("face_up", "");
  if (c->face_down.empty()) s.Fail("face_down", "required: the get-up clip from lying face down");
  if (c->face_up.empty()) s.Fail("face_up", "required: the get-up clip from lying face up");
  c->start_fallen = NonNegative(s, "start_fallen", c->start_fallen);
  c->start_getting_up = NonNegative(s, "start_getting_up", c->start_getting_up);
  if (c->start_fallen + c->start_getting_up > 1) {
    s.Fail("start_getting_up", "start_fallen + start_getting_up must be at most 1");
  }
  c->get_up_reward_scale = NonNegative(s, "get_up_reward_scale", c->get_up_reward_scale);
  if (c->get_up_reward_scale > 1) s.Fail("get_up_reward_scale", "must be in [0, 1]");
  c->give_up_after = Positive(s, "give_up_after", c->give_up_after);
  c->early_termination = s.Get<bool>("early_termination", c->early_termination);
  c->early_termination_height =
      Positive(s, "early_termination_height", c->early_termination_height);
  if (c->early_termination_height > 1) s.Fail("early_termination_height", "must be at most 1 m");
  c->stand_after_get_up = NonNegative(s, "stand_after_get_up", c->stand_after_get_up);
  s.Finish();
}
}  // namespace

EnvConfig ReadEnvConfig(const ConfigSection& s, const std::string& default_character) {
  EnvConfig c;
  c.character = s.GetPath("character", default_character);
  c.motion = s.GetPath("motion", "");
  ReadSteering(s, &c.steering);
  if (c.steering.enabled()) {
    if (!c.motion.empty()) {
      s.Fail("motion", "with a steering section the clips are its `motions`; remove `motion`");
    }
    c.motion = c.steering.motions.front().motion;
  } else if (c.motion.empty()) {
    s.Fail("motion", "required: the reference clip to imitate (or a `steering` motion set)");
  }
  c.control_frequency = Positive(s, "control_frequency", c.control_frequency);
  c.substeps = s.Get<int>("substeps", c.substeps);
  if (c.substeps < 1) s.Fail("substeps", "must be at least 1");
  c.max_episode_steps = s.Get<int>("max_episode_steps", c.max_episode_steps);
  if (c.max_episode_steps < 1) s.Fail("max_episode_steps", "must be at least 1");
  std::string mode = s.Get<std::string>("action_mode", "absolute");
  if (mode == "absolute") {
    c.action_mode = ActionMode::kAbsolute;
  } else if (mode == "offset") {
    c.action_mode = ActionMode::kOffset;
  } else {
    s.Fail("action_mode", "expected 'absolute' or 'offset', got '" + mode + "'");
  }
  c.offset_scale = Positive(s, "offset_scale", c.offset_scale);
  c.random_start = s.Get<bool>("random_start", c.random_start);
  c.start_phase = s.Get<double>("start_phase", c.start_phase);
  if (!(c.start_phase >= 0 && c.start_phase < 1)) s.Fail("start_phase", "must be in [0, 1)");
  if (s.Has("allowed_contacts") && s.IsList("allowed_contacts")) {
    c.contacts_from_clip = false;
    c.allowed_contacts = s.GetStringList("allowed_contacts", {});
  } else if (s.Get<std::string>("allowed_contacts", "auto") != "auto") {
    s.Fail("allowed_contacts",
           "expected 'auto' (the bodies the clip puts on the floor) or a list of bodies, e.g. "
           "[right_ankle, left_ankle]");
  }
  c.max_root_distance = Positive(s, "max_root_distance", c.max_root_distance);
  std::string sync = s.Get<std::string>("sync_reference", "position_and_heading");
  if (sync == "none") {
    c.reference_sync = ReferenceSync::kNone;
  } else if (sync == "position") {
    c.reference_sync = ReferenceSync::kPosition;
  } else if (sync == "position_and_heading") {
    c.reference_sync = ReferenceSync::kPositionAndHeading;
  } else {
    s.Fail("sync_reference",
           "expected 'none', 'position' or 'position_and_heading', got '" + sync + "'");
  }

  ReadPerturbations(s, &c.perturbations);
  ReadRecovery(s, &c.recovery);

  ConfigSection weights = s.Section("joint_weights");
  for (auto& [name, w] : c.joint_weights) w = NonNegative(weights, name, w);
  weights.Finish();

  ConfigSection r = s.Section("reward");
  RewardConfig& rc = c.reward;
  rc.rotation_weight = NonNegative(r, "rotation_weight", rc.rotation_weight);
  rc.velocity_weight = NonNegative(r, "velocity_weight", rc.velocity_weight);
  rc.end_effector_weight = NonNegative(r, "end_effector_weight", rc.end_effector_weight);
  rc.com_weight = NonNegative(r, "com_weight", rc.com_weight);
  rc.root_weight = NonNegative(r, "root_weight", rc.root_weight);
  rc.rotation_scale = NonNegative(r, "rotation_scale", rc.rotation_scale);
  rc.velocity_scale = NonNegative(r, "velocity_scale", rc.velocity_scale);
  rc.end_effector_scale = NonNegative(r, "end_effector_scale", rc.end_effector_scale);
  rc.com_scale = NonNegative(r, "com_scale", rc.com_scale);
  rc.root_scale = NonNegative(r, "root_scale", rc.root_scale);
  rc.root_rotation_factor = NonNegative(r, "root_rotation_factor", rc.root_rotation_factor);
  rc.root_linear_velocity_factor =
      NonNegative(r, "root_linear_velocity_factor", rc.root_linear_velocity_factor);
  rc.root_angular_velocity_factor =
      NonNegative(r, "root_angular_velocity_factor", rc.root_angular_velocity_factor);
  if (rc.MaxReward() <= 0) r.Fail("rotation_weight", "at least one reward weight must be positive");
  r.Finish();
  s.Finish();
  return c;
}

}  // namespace ragdoll::sim
