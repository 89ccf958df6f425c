// Pushes given while a trained policy runs (eval --commands, render, bake): at moments a script
// names, or at random every few seconds. Training's own pushes are sim/perturbations.h; the push
// trials of eval --pushes are push_evaluation.h.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "character/character.h"
#include "sim/imitation_env.h"

namespace ragdoll::eval {

// A push at a moment: `impulse` N s spread over `duration` s on `body` (empty: the pelvis),
// horizontally toward a side of where the character faces when it starts.
struct TimedPush {
  double at = 0;  // s
  double impulse = 0;
  std::string direction = "forward";  // forward, backward, left, right
  double duration = 0.2;
  std::string body;
};

// The angle of a side from where the character faces, radians counter-clockwise; false for a
// name that is not forward, backward, left or right.
bool SideAngle(const std::string& direction, double* angle);

// Gives timed pushes as the run's clock passes them, as external forces on the environment.
class ScriptedPushes {
 public:
  // In time order, none overlapping. Throws ConfigError for a body the character does not have
  // or an unknown direction.
  ScriptedPushes(std::vector<TimedPush> pushes, const character::Character& character);
  // Before the control step that starts at run time `t`: starts or ends a push; true when one
  // started.
  bool Before(sim::ImitationEnv& env, double t);
  // The push under way or ended less than `linger` s before `t` ("push 60 N s left"), or "".
  std::string Describe(double t, double linger) const;

 private:
  std::vector<TimedPush> pushes_;
  std::vector<int> bodies_;    // per push
  std::vector<double> sides_;  // per push, SideAngle of its direction
  size_t next_ = 0;            // the first push not yet started
  int active_ = -1;            // the push under way
};

// Pushes on one body every `every` s (the first after `every`), each for 0.2 s as in DeepMimic's
// protocol, toward a uniformly random horizontal direction, with an impulse uniform in
// [impulse_min, impulse_max] N s; all drawn from the seed. `every` <= 0: none.
class RandomPushes {
 public:
  RandomPushes(double impulse_min, double impulse_max, double every, double control_dt,
               uint64_t seed, int body);
  // Before control step `step` (0 the first): starts the push that falls due or ends the one
  // that has lasted its time; true when one started.
  bool Before(sim::ImitationEnv& env, int step);
  int count() const { return count_; }
  double last_impulse() const { return last_impulse_; }  // N s
  double last_angle() const { return last_angle_; }      // radians, world

 private:
  double impulse_min_, impulse_max_, dt_;
  int steps_, interval_, body_;
  std::mt19937_64 rng_;
  int count_ = 0, started_ = -1;
  double last_impulse_ = 0, last_angle_ = 0;
};

}  // namespace ragdoll::eval
