#include "sim/motion_set.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "character/ground_contacts.h"
#include "character/motion_io.h"
#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

// Reflection in the x-z plane (y -> -y) of a rotation: the axis's x and z flip, the angle stays.
character::Quat Reflect(const character::Quat& q) { return {q[0], -q[1], q[2], -q[3]}; }

void AddGetUpClips(const RecoveryConfig& recovery, std::vector<MotionSetEntry>* entries) {
  if (!recovery.enabled()) return;
  for (const auto& [name, file] :
       {std::pair<std::string, std::string>{"get_up_face_down", recovery.face_down},
        {"get_up_face_up", recovery.face_up}}) {
    MotionSetEntry e;
    e.name = name;
    e.clip = std::make_shared<const character::MotionClip>(character::LoadMotion(file));
    if (e.clip->loop()) {
      throw ConfigError(file + ": get-up clip '" + name +
                        "' loops; a get-up plays once and hands back (\"loop\": false)");
    }
    e.get_up = true;
    entries->push_back(std::move(e));
  }
}

}  // namespace

MotionSet::MotionSet(std::vector<MotionSetEntry> entries) : entries_(std::move(entries)) {
  for (int i = 0; i < size(); ++i) {
    const MotionSetEntry& e = entries_[i];
    if (!e.clip) throw std::invalid_argument("motion set entry '" + e.name + "' has no clip");
    if (e.transition()) {
      if (e.from < 0 || e.from >= size() || e.to >= size() || entries_[e.from].transition() ||
          entries_[e.to].transition()) {
        throw std::invalid_argument("transition '" + e.name + "' does not lead between clips");
      }
    } else if (!e.get_up) {
      commands_.push_back(i);
    }
  }
  if (commands_.empty()) throw std::invalid_argument("a motion set needs a non-transition clip");
}

int MotionSet::Find(const std::string& name) const {
  for (int i = 0; i < size(); ++i) {
    if (entries_[i].name == name) return i;
  }
  return -1;
}

int MotionSet::Transition(int from, int to) const {
  for (int i = 0; i < size(); ++i) {
    if (entries_[i].from == from && entries_[i].to == to) return i;
  }
  return -1;
}

int MotionSet::Nearest(const Command& command) const {
  int best = commands_.front();
  double best_distance = std::numeric_limits<double>::infinity();
  for (int i : commands_) {
    const Command& c = entries_[i].command;
    double d = std::pow(c.forward - command.forward, 2) + std::pow(c.left - command.left, 2) +
               std::pow(c.turn - command.turn, 2);
    if (d < best_distance) {
      best_distance = d;
      best = i;
    }
  }
  return best;
}

Command MeasureCommand(const character::MotionClip& clip) {
  Command c;
  for (int i = 0; i + 1 < clip.num_frames(); ++i) {
    const character::Pose& a = clip.frame(i);
    const character::Pose& b = clip.frame(i + 1);
    double yaw_a = character::YawOf(a.root_rotation), yaw_b = character::YawOf(b.root_rotation);
    double mid = yaw_a + 0.5 * character::WrapAngle(yaw_b - yaw_a);
    double dx = b.root_position[0] - a.root_position[0];
    double dy = b.root_position[1] - a.root_position[1];
    c.forward += std::cos(mid) * dx + std::sin(mid) * dy;
    c.left += -std::sin(mid) * dx + std::cos(mid) * dy;
    c.turn += character::WrapAngle(yaw_b - yaw_a);
  }
  const double d = clip.duration();
  c.forward /= d;
  c.left /= d;
  c.turn /= d;
  return c;
}

character::MotionClip Mirror(const character::MotionClip& clip,
                             const character::Character& character, const std::string& name) {
  const auto& joints = character.joints();
  std::vector<int> twin(joints.size());
  for (size_t j = 0; j < joints.size(); ++j) {
    std::string n = joints[j].name;
    if (n.rfind("right_", 0) == 0) {
      n = "left_" + n.substr(6);
    } else if (n.rfind("left_", 0) == 0) {
      n = "right_" + n.substr(5);
    }
    twin[j] = -1;
    for (size_t k = 0; k < joints.size(); ++k) {
      if (joints[k].name == n) twin[j] = static_cast<int>(k);
    }
    if (twin[j] < 0) {
      throw std::invalid_argument("cannot mirror: joint '" + joints[j].name + "' has no '" + n +
                                  "' twin");
    }
  }
  std::vector<character::Pose> frames;
  std::vector<double> durations;
  for (int f = 0; f < clip.num_frames(); ++f) {
    const character::Pose& p = clip.frame(f);
    character::Pose m;
    m.root_position = {p.root_position[0], -p.root_position[1], p.root_position[2]};
    m.root_rotation = Reflect(p.root_rotation);
    m.joint_rotations.resize(p.joint_rotations.size());
    for (size_t j = 0; j < joints.size(); ++j) {
      m.joint_rotations[j] = Reflect(p.joint_rotations[twin[j]]);
    }
    frames.push_back(std::move(m));
    durations.push_back(clip.frame_duration(f));
  }
  return character::MotionClip(name, clip.loop(), std::move(durations), std::move(frames),
                               clip.cycle_transform());
}

std::vector<std::string> GroundContacts(const MotionSet& motions,
                                        const character::Character& character) {
  std::vector<std::string> all;
  for (const MotionSetEntry& e : motions.entries()) {
    if (e.get_up) continue;
    for (const std::string& b : character::ClipGroundContacts(*e.clip, character)) {
      if (std::find(all.begin(), all.end(), b) == all.end()) all.push_back(b);
    }
  }
  return all;
}

void ResolveAllowedContacts(const MotionSet& motions, const character::Character& character,
                            EnvConfig* config) {
  if (config->contacts_from_clip && config->allowed_contacts.empty()) {
    config->allowed_contacts = GroundContacts(motions, character);
  }
}

std::shared_ptr<const MotionSet> LoadMotionSet(const EnvConfig& config,
                                               const character::Character& character) {
  std::vector<MotionSetEntry> entries;
  if (!config.steering.enabled()) {
    auto clip = std::make_shared<const character::MotionClip>(character::LoadMotion(config.motion));
    entries.push_back({clip->name(), clip, MeasureCommand(*clip)});
    AddGetUpClips(config.recovery, &entries);
    return std::make_shared<const MotionSet>(std::move(entries));
  }
  const auto& items = config.steering.motions;
  for (const MotionSetItem& item : items) {
    character::MotionClip clip = character::LoadMotion(item.motion);
    if (item.mirror) clip = Mirror(clip, character, item.name);
    if (item.transition() && clip.loop()) {
      throw ConfigError(item.motion + ": transition '" + item.name +
                        "' is a looping clip; a transition plays once (\"loop\": false)");
    }
    MotionSetEntry e;
    e.name = item.name;
    e.command = item.command_from_clip ? MeasureCommand(clip) : item.command;
    e.clip = std::make_shared<const character::MotionClip>(std::move(clip));
    entries.push_back(std::move(e));
  }
  for (size_t i = 0; i < items.size(); ++i) {
    if (!items[i].transition()) continue;
    for (size_t k = 0; k < items.size(); ++k) {
      if (items[k].name == items[i].from) entries[i].from = static_cast<int>(k);
      if (items[k].name == items[i].to) entries[i].to = static_cast<int>(k);
    }
    entries[i].command = entries[entries[i].to].command;
  }
  AddGetUpClips(config.recovery, &entries);
  return std::make_shared<const MotionSet>(std::move(entries));
}

}  // namespace ragdoll::sim
