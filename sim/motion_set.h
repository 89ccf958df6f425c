// The clips of a steering task, each with the command it demonstrates, and the transitions
// between them (EnvConfig::steering). Loaded once per process and shared by its environments.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"
#include "sim/env_config.h"

namespace ragdoll::sim {

struct MotionSetEntry {
  std::string name;
  std::shared_ptr<const character::MotionClip> clip;
  Command command;  // a transition's is its `to` entry's
  int from = -1;    // a transition: the entries it leads between; -1 otherwise
  int to = -1;
  // A get-up clip (EnvConfig::recovery): played after a fall, never named by a command.
  bool get_up = false;
  bool transition() const { return to >= 0; }
};

class MotionSet {
 public:
  // Throws std::invalid_argument for an empty set or a transition that names no entry.
  explicit MotionSet(std::vector<MotionSetEntry> entries);

  const std::vector<MotionSetEntry>& entries() const { return entries_; }
  const MotionSetEntry& entry(int i) const { return entries_[i]; }
  int size() const { return static_cast<int>(entries_.size()); }
  // The entries a command can name (neither a transition nor a get-up clip), in set order.
  const std::vector<int>& commands() const { return commands_; }
  // The entry called `name`, or -1.
  int Find(const std::string& name) const;
  // The transition clip from entry `from` to entry `to`, or -1.
  int Transition(int from, int to) const;
  // The command entry whose command is closest to `command` (turn counted at 1 m/s per rad/s).
  int Nearest(const Command& command) const;

 private:
  std::vector<MotionSetEntry> entries_;
  std::vector<int> commands_;
};

// The command a clip demonstrates: its root's mean planar velocity expressed in its own heading
// frame, frame by frame, and its mean turn rate, over one pass of the clip.
Command MeasureCommand(const character::MotionClip& clip);

// The clip reflected in the character's sagittal (x-z) plane: every right_* joint takes the
// mirrored rotation of its left_* twin and the other way round. Walking left from walking right.
character::MotionClip Mirror(const character::MotionClip& clip,
                             const character::Character& character, const std::string& name);

// Every body some clip of the set other than a get-up clip puts on the floor (ClipGroundContacts),
// feet included.
std::vector<std::string> GroundContacts(const MotionSet& motions,
                                        const character::Character& character);
// `allowed_contacts: auto` resolved once: fills config->allowed_contacts with GroundContacts
// unless the config gives its own list or it is already filled (so a process resolves it once
// and every environment built from the config reuses the list).
void ResolveAllowedContacts(const MotionSet& motions, const character::Character& character,
                            EnvConfig* config);

// Loads, mirrors and measures every clip of `steering` (ConfigError naming the file when one
// does not load). The set of a config without steering is its one clip, command measured. With
// `recovery`, the two get-up clips follow, named "get_up_face_down" and "get_up_face_up".
std::shared_ptr<const MotionSet> LoadMotionSet(const EnvConfig& config,
                                               const character::Character& character);

}  // namespace ragdoll::sim
