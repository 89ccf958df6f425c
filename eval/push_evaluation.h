// Push trials on a trained policy (robustness): from a random phase the deterministic policy runs
// `settle` seconds, a body is pushed horizontally for `duration` seconds with a force of
// impulse / duration, and the trial fails if the character falls (a body it may not put down
// touches the ground, or the simulation diverges) within `observe` seconds after. A push that
// only carries the character away from its reference is not a fall. Every impulse and direction
// meets the same start phases (and random directions), drawn from the seed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/wire.h"
#include "sim/env_config.h"

namespace ragdoll::eval {

// A sweep over given impulses.
struct PushConfig {
  std::string body = "root";
  std::vector<double> impulses = {0, 10, 20, 30, 40, 60, 80, 100};  // newton-seconds
  double duration = 0.1;
  int trials = 20;
  double settle = 1.0;
  double observe = 2.0;
  std::string direction = "random";  // or forward, backward, left, right (of the heading)
  // Steering runs: the command held through every trial (empty: training's random commands).
  std::string command;
};

struct PushResult {
  double impulse = 0;  // N s
  double force = 0;    // N
  double fall_rate = 0;
  double normalized_return = 0;  // mean over the trials' whole episodes so far
};

struct RobustnessResult {
  PushConfig config;
  std::vector<PushResult> results;
  // The largest impulse survived in at least 90 % of the trials, this one and all smaller
  // ones; -1 if even the smallest is not.
  double survived_90 = -1;
  std::string ToTable() const;
  std::string ToJson() const;  // an object, for the evaluation JSON's "perturbation"
};

// Throws ConfigError for an unknown body, direction or command.
RobustnessResult EvaluatePushes(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const PushConfig& push, uint64_t seed);

// DeepMimic's protocol: pushes on the pelvis for 0.2 s toward each side of the heading; for each,
// the largest impulse survived in at least 90 % of the trials, found by doubling from `start`
// until a push fails and then halving the interval down to `resolution`. The whole body's change
// of velocity (impulse / mass) compares characters of other masses.
struct PushProtocolConfig {
  std::string body = "root";
  double duration = 0.2;
  int trials = 20;
  double settle = 1.0;
  double observe = 2.0;
  std::string command;       // as PushConfig::command
  double start = 10;         // N s
  double max_impulse = 640;  // N s; the search stops there
  double resolution = 2;     // N s
  std::vector<std::string> directions = {"forward", "backward", "left", "right"};
};

struct DirectionResult {
  std::string direction;
  double survived_90 = 0;      // N s; 0 when even `start` fails
  double velocity_change = 0;  // survived_90 / mass, m/s
  bool at_limit = false;       // survived max_impulse: the figure is a lower bound
  int impulses_tried = 0;
};

struct PushProtocolResult {
  PushProtocolConfig config;
  double mass = 0;  // kg, the whole character
  std::vector<DirectionResult> directions;
  std::string ToTable() const;
  std::string ToJson() const;  // an object, the evaluation JSON's "perturbation"."protocol"
};

// Throws ConfigError for an unknown body, direction or command, or settings that make no search.
PushProtocolResult EvaluatePushProtocol(const sim::EnvConfig& env,
                                        const v1::PolicySnapshot& snapshot,
                                        const PushProtocolConfig& protocol, uint64_t seed);

}  // namespace ragdoll::eval
