// Random pushes while training (robustness; EnvConfig::perturbations), with a curriculum per
// environment. Its own random stream, so that turning pushes on leaves the episodes' start
// phases as they were.
#pragma once

#include <mujoco/mujoco.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "actor/sim/character.h"
#include "actor/sim/env_config.h"
#include "actor/sim/task.h"

namespace ragdoll::sim {

class Perturbations {
 public:
  // Throws ConfigError for a body the character lacks.
  Perturbations(const PerturbationConfig& config, const Character& character, double control_dt,
                uint64_t seed);

  // The episode figures they add: the level.
  static std::vector<FigureSpec> FigureSpecs() { return {{"push_level", "N s"}}; }

  // A new episode: nothing in flight, the next push after a random interval. The level stays.
  void Reset();
  // Before a control step's physics: starts, holds or ends a push (d->xfrc_applied). While
  // `may_push` is false (the character gets up) a push that falls due waits, so that the
  // curriculum judges pushes on a character that stands.
  void BeforeStep(mjData* d, bool may_push = true);
  // After it: whether the character fell in it (ending the episode, or seen by a task that gets
  // up).
  void AfterStep(bool fell);

  double level() const { return level_; }
  int pushes() const { return pushes_; }

 private:
  void Judge(bool survived);

  PerturbationConfig config_;
  std::vector<int> bodies_;
  double control_dt_;
  std::mt19937_64 rng_;
  double level_;
  int steps_to_next_ = 0;  // control steps until the next push starts
  int push_steps_left_ = 0;
  int pushed_body_ = -1;
  int judge_steps_left_ = 0;  // of the push being judged; 0: none
  int judged_ = 0, survived_ = 0;
  int pushes_ = 0;
};

}  // namespace ragdoll::sim
