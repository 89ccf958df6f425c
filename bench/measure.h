// The machine's own limits and what each half of a training makes of them, measured in this
// process on one core: raw mj_step against the environment, the actor with its policy against
// the environments alone, the PPO update against raw libtorch forward+backward+Adam. Shared by
// the ragdoll-bench-* programs and `ragdoll doctor`.
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "character/character.h"
#include "learner/learner.h"
#include "run/experiment.h"
#include "sim/imitation_env.h"

namespace ragdoll::bench {

// One recorded environment run (PD targets at the reference pose): the controls of every step
// and the states it reset to, for the raw physics to replay.
struct Recording {
  std::vector<float> actions;     // steps x action_size
  std::vector<double> controls;   // steps x nu
  std::vector<int> reset_before;  // 1 where the step follows a reset
  std::vector<double> reset_qpos, reset_qvel;
};

Recording Record(const sim::EnvConfig& config,
                 std::shared_ptr<const character::Character> character,
                 std::shared_ptr<const sim::MotionSet> motions, int steps, uint64_t seed);

// Physics steps per second of plain mj_step replaying the recording, `substeps` per control step.
double RawPhysicsRate(const character::Character& character, int substeps, const Recording& r);

struct PhysicsFigures {
  double steps_per_second = 0;  // raw mj_step, replaying an environment run's controls and resets
  int substeps = 1;
  double control_bound() const { return steps_per_second / substeps; }  // control steps/s
};

// Median of `repeats` replays of a `steps`-control-step run of the config's environment.
PhysicsFigures MeasurePhysics(const sim::EnvConfig& environment, int steps, int repeats);

struct ActorFigures {
  double with_policy = 0;   // samples/s with normalisation, the batched forward and sampling
  double env_only = 0;      // the same environments replaying the sampled actions
  double ratio = 0;         // median of env_only's time over with_policy's
  double packed_ratio = 0;  // the same with packing the segments for the wire
  int64_t resets = 0;
  double bytes_per_sample = 0;
};

// One thread, K environments, `steps` per environment per repeat.
ActorFigures MeasureActor(const run::Experiment& e, int environments, int steps, int repeats);

struct LearnerFigures {
  double update = 0;  // PPO update samples/s per epoch
  double raw = 0;     // raw libtorch fwd+bwd+Adam samples/s on minibatches of the same size
  double ratio = 0;   // median of update / raw
  double gflops = 0;  // the update's matrix products (6 per weight per sample) per second
  int64_t buffer = 0, minibatch = 0;
};

// Fills the learner's buffer (its share, for a replica) with synthetic segments of the right
// sizes, their actions and log-probabilities from the learner's policy as an actor's would be.
// Foreign log-probabilities would not do: as the policy drifts from them, the importance ratios
// and the gradients through them underflow to denormal floats, which Intel CPUs multiply far more
// slowly (docs/benchmarks.md has the figures).
void FillWithSyntheticSegments(learner::Learner& l, int T, int O, int A, std::mt19937& rng);

// The update on a buffer of synthetic segments, at the intra-op thread count already set.
LearnerFigures MeasureLearner(const run::Experiment& e, int repeats);

}  // namespace ragdoll::bench
