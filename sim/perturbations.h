// Random pushes while training (robustness; EnvConfig::perturbations), with a curriculum per
// environment (and per situation with `per_situation`). Its own random stream, so that turning
// pushes on leaves the episodes' start phases as they were.
#pragma once

#include <mujoco/mujoco.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "character/character.h"
#include "sim/env_config.h"
#include "sim/task.h"

namespace ragdoll::sim {

// Where a push would land, for a curriculum per situation: the character's heading (rad, the
// root's yaw) and whether it is told to stand still.
struct PushSituation {
  double heading = 0;
  bool still = false;
};

class Perturbations {
 public:
  // Throws ConfigError for a body the character lacks.
  Perturbations(const PerturbationConfig& config, const character::Character& character,
                double control_dt, uint64_t seed);

  // Directions in quarters of the character's heading, counter-clockwise seen from above.
  enum Quarter { kForward, kLeft, kBackward, kRight };
  static constexpr int kQuarters = 4;

  // The episode figures they add: the level (the mean over situations).
  static std::vector<FigureSpec> FigureSpecs() { return {{"push_level", "N s"}}; }

  // A new episode: nothing in flight, the next push after a random interval. The level stays.
  void Reset();
  // Before a control step's physics: starts, holds or ends a push (d->xfrc_applied). While
  // `may_push` is false (the character gets up) a push that falls due waits, so that the
  // curriculum judges pushes on a character that stands. `situation` places a push drawn with
  // per_situation; the uniform draw ignores it.
  void BeforeStep(mjData* d, bool may_push = true, const PushSituation& situation = {});
  // After it: whether the character fell in it (ending the episode, or seen by a task that gets
  // up).
  void AfterStep(bool fell);

  double level() const;
  // The level of pushes on `bodies[body]` toward `quarter` while told to stand `still`, or not
  // (the one level without per_situation).
  double level(int body, Quarter quarter, bool still) const;
  // The recent share of falls after those pushes (an exponential average, 0.5 before any).
  double fall_share(int body, Quarter quarter, bool still) const;
  int pushes() const { return pushes_; }

 private:
  struct Curriculum {
    double level;
    int judged = 0, survived = 0;  // in the current window
    double fall_share = 0.5;
  };
  int Index(int body, int quarter, bool still) const;
  // The world-frame direction of a push on `bodies_[body]` (rad), and its curriculum.
  double DrawAngle(int body, const PushSituation& situation, int* curriculum);
  void Judge(bool survived);

  PerturbationConfig config_;
  std::vector<int> bodies_;
  double control_dt_;
  std::mt19937_64 rng_;
  std::vector<Curriculum> curricula_;  // one, or bodies × quarters × {moving, still}
  int judged_curriculum_ = 0;          // of the push being judged
  int steps_to_next_ = 0;              // control steps until the next push starts
  int push_steps_left_ = 0;
  int pushed_body_ = -1;
  int judge_steps_left_ = 0;  // of the push being judged; 0: none
  int pushes_ = 0;
};

}  // namespace ragdoll::sim
