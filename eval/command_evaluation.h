// Scripted evaluation of a steering policy: the character follows a command script (a file, or
// a seeded random one) and is scored on speed and heading tracking, imitation while it walks,
// falls, and the success of every kind of transition between commands.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "character/character.h"
#include "common/wire.h"
#include "eval/scripted_pushes.h"
#include "sim/env_config.h"
#include "sim/motion_set.h"

namespace ragdoll::eval {

struct CommandScript {
  struct Change {
    double at = 0;        // seconds from the start
    std::string command;  // a motion-set entry that is not a transition
  };
  std::vector<Change> changes;    // in time order, the first at 0
  std::vector<TimedPush> pushes;  // in time order, none overlapping
  double duration = 0;            // seconds
};

// A YAML file:
//   duration: 30             # seconds
//   commands:
//     - {at: 0, command: stand}
//     - {at: 2, command: walk}
//   pushes:                  # optional
//     - {at: 5, impulse: 60, direction: left}
//     - {at: 9, impulse: 200, direction: backward, body: chest, duration: 0.1}
// Throws ConfigError naming the file and line for an unknown command, direction or body, times
// out of order, a first change after 0, overlapping pushes, or a duration not after the last
// change.
CommandScript ReadCommandScript(const std::string& path, const sim::MotionSet& motions,
                                const character::Character& character);

// Commands drawn uniformly from the set (never the current one again), each held for a uniform
// random interval in [interval_min, interval_max] seconds.
CommandScript RandomCommandScript(const sim::MotionSet& motions, double duration,
                                  double interval_min, double interval_max, uint64_t seed);

// Knock-downs of a policy that gets up (EnvConfig::recovery) and the time until it is back on
// command. A knock-down begins at the push that felled the character (one that started at most
// kPushToFall s before the fall) or else at the fall, spans any further falls, and ends once the
// character has tracked its command (speed and heading errors within tolerance, no get-up
// playing) for `hold` s; its time runs to the start of that hold, as a settling time does (from
// then on it walks as told).
class KnockDownClock {
 public:
  static constexpr double kPushToFall = 1.5;  // s
  KnockDownClock(double speed_tolerance, double heading_tolerance, double hold);
  void Pushed(double t);
  // After each control step, the one that ended at run time `t`: whether the task saw a new fall in
  // it, whether a get-up plays, and the steering errors (m/s, rad).
  void Step(double t, bool fell, bool getting_up, double speed_error, double heading_error);
  // The run ended at `t`: a knock-down still open counts as not back if `window` s have passed
  // since it began, and is left out otherwise (the run was too short to tell); `gave_up` (the
  // episode ended in a fall it did not get up from) counts one not back in any case.
  void End(double t, double window, bool gave_up);
  // Per knock-down, seconds until back on command; infinity: never back.
  const std::vector<double>& seconds() const { return seconds_; }

 private:
  double speed_tolerance_, heading_tolerance_, hold_;
  double previous_ = 0;     // when the last step ended (the run starts at 0)
  double pushed_ = -1e9;    // when the latest push started
  double down_since_ = -1;  // the open knock-down's beginning; < 0: none open
  double good_since_ = -1;  // the open knock-down: since when it has tracked its command
  std::vector<double> seconds_;
};

struct CommandEvalConfig {
  int runs = 20;       // scripted runs, from random clip phases
  bool random = true;  // a new random script per run; else `script` for every run
  CommandScript script;
  double duration = 60;  // of each random script, s
  // Tracking is scored once a command has held this long (a transition has had time to play),
  // s; a transition succeeds when the character has not fallen `transition_window` seconds after
  // the change and, over its last half, tracks speed within transition_speed and heading within
  // transition_heading.
  double settle = 1.5;
  double transition_window = 3.0;
  double transition_speed = 0.25;    // m/s
  double transition_heading = 0.44;  // rad (25 degrees)
  // Pushes while the script plays besides its own: every `push_interval` seconds (0: none) on
  // the pelvis for 0.2 s, toward a random horizontal direction with an impulse drawn uniformly
  // from [0, push_max] N s (RandomPushes; the seed draws them).
  double push_interval = 0;
  double push_max = 60;
  // A knock-down (KnockDownClock) is back on command when the character has tracked it within
  // transition_speed and transition_heading for back_hold s; the share back within back_window s
  // is reported.
  double back_hold = 1.0;
  double back_window = 6.0;
};

struct CommandTracking {
  double seconds = 0;        // settled time scored
  double speed_error = 0;    // mean |v - v*|, m/s
  double heading_error = 0;  // mean |heading - desired|, rad
  double imitation = 0;      // mean imitation reward / its maximum, 0-1
};

struct TransitionOutcome {
  int count = 0;
  int succeeded = 0;
};

struct CommandEvalResult {
  int runs = 0;
  // Runs that ended in a fall: a fall ends the run, or, for a policy that gets up
  // (EnvConfig::recovery), still being down give_up_after seconds after it.
  int falls = 0;
  int knocked_down = 0;  // runs with at least one fall, got up or not
  int pushes = 0;        // pushes given, the script's and push_interval's
  // A policy that gets up: per knock-down (KnockDownClock), s until back on command; infinity:
  // not back.
  std::vector<double> knockdown_seconds;
  double back_window = 6.0;            // s: CommandEvalConfig::back_window
  int back_within() const;             // knock-downs back on command within back_window
  double median_back_seconds() const;  // infinity when half or more never came back
  double seconds = 0;                  // simulated in all runs
  CommandTracking overall;             // every settled step
  CommandTracking moving;              // settled steps of commands that move or turn
  std::map<std::string, CommandTracking> per_command;
  std::map<std::string, TransitionOutcome> transitions;  // "from->to"
  double fall_rate() const { return runs ? static_cast<double>(falls) / runs : 0; }
  std::string ToTable() const;
  std::string ToJson() const;  // an object, for the evaluation JSON's "commands"
};

// Throws std::invalid_argument when `env` has no steering task.
CommandEvalResult EvaluateCommands(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                   const CommandEvalConfig& config, uint64_t seed);

}  // namespace ragdoll::eval
