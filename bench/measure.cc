#include "bench/measure.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

#include "actor/rollout.h"
#include "common/median.h"
#include "common/wire.h"
#include "learner/learner.h"
#include "learner/raw_training.h"
#include "sim/motion_set.h"

namespace ragdoll::bench {
namespace {

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

Recording Record(const sim::EnvConfig& config,
                 std::shared_ptr<const character::Character> character,
                 std::shared_ptr<const sim::MotionSet> motions, int steps, uint64_t seed) {
  sim::ImitationEnv env(character, motions, config, seed);
  const mjModel* m = character->model();
  std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size);
  Recording r;
  env.Reset(obs.data());
  bool reset = true;
  for (int i = 0; i < steps; ++i) {
    if (reset) {
      r.reset_qpos.insert(r.reset_qpos.end(), env.data().qpos, env.data().qpos + m->nq);
      r.reset_qvel.insert(r.reset_qvel.end(), env.data().qvel, env.data().qvel + m->nv);
    }
    r.reset_before.push_back(reset ? 1 : 0);
    env.ReferenceAction(action.data());
    r.actions.insert(r.actions.end(), action.begin(), action.end());
    sim::StepResult s = env.Step(action.data(), obs.data());
    r.controls.insert(r.controls.end(), env.data().ctrl, env.data().ctrl + m->nu);
    reset = s.terminated || s.truncated;
    if (reset) env.Reset(obs.data());
  }
  return r;
}

double RawPhysicsRate(const character::Character& character, int substeps, const Recording& r) {
  const mjModel* m = character.model();
  character::DataPtr d = character.MakeData();
  const int steps = static_cast<int>(r.reset_before.size());
  int resets = 0;
  const auto start = Clock::now();
  for (int i = 0; i < steps; ++i) {
    if (r.reset_before[i]) {
      mj_resetData(m, d.get());
      std::copy_n(r.reset_qpos.data() + resets * m->nq, m->nq, d->qpos);
      std::copy_n(r.reset_qvel.data() + resets * m->nv, m->nv, d->qvel);
      mj_forward(m, d.get());
      ++resets;
    }
    std::copy_n(r.controls.data() + i * m->nu, m->nu, d->ctrl);
    for (int s = 0; s < substeps; ++s) mj_step(m, d.get());
  }
  return steps * substeps / Since(start);
}

PhysicsFigures MeasurePhysics(const sim::EnvConfig& environment, int steps, int repeats) {
  auto character = character::Character::Load(environment.character, environment.physics_dt());
  auto motions = sim::LoadMotionSet(environment, *character);
  const Recording r = Record(environment, character, motions, steps, 1);
  std::vector<double> rates;
  for (int i = 0; i < repeats; ++i) {
    rates.push_back(RawPhysicsRate(*character, environment.substeps, r));
  }
  PhysicsFigures f;
  f.steps_per_second = Median(rates);
  f.substeps = environment.substeps;
  return f;
}

ActorFigures MeasureActor(const run::Experiment& e, int K, int steps, int repeats) {
  actor::RolloutWorker worker(e.environment, K, steps, 1, "bench");
  GaussianPolicy policy(worker.spec().observation_size, worker.spec().action_size,
                        e.trainer.network);
  worker.SetPolicy(MakeSnapshot(policy, RunningStats(worker.spec().observation_size), 0, 0));

  // The environments alone: a second set of K environments with the same seeds replays, step
  // for step, the actions the policy loop sampled. Both loops therefore simulate the identical
  // trajectories (rollouts are bit-identical for a seed), fall and reset at the same steps; the
  // difference is only the policy: normalisation, the batched forward, sampling and building
  // the segments. Packing the segments for the wire is timed separately.
  auto character = character::Character::Load(e.environment.character, e.environment.physics_dt());
  auto motions = sim::LoadMotionSet(e.environment, *character);
  std::vector<std::unique_ptr<sim::ImitationEnv>> envs;
  for (int k = 0; k < K; ++k) {
    envs.push_back(std::make_unique<sim::ImitationEnv>(character, motions, e.environment, 1 + k));
  }
  const int O = worker.spec().observation_size, A = worker.spec().action_size;
  std::vector<float> obs(static_cast<size_t>(K) * O);
  for (int k = 0; k < K; ++k) envs[k]->Reset(obs.data() + k * O);

  std::vector<double> with_policy, env_only, ratio, packed_ratio;
  ActorFigures f;
  size_t bytes = 0;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    std::vector<v1::TrajectorySegment> segments = worker.Collect();
    const double policy_seconds = Since(t0);
    const auto tp = Clock::now();
    for (const auto& s : segments) {
      bytes += wire::Pack(v1::KIND_TRAJECTORY, "bench", "bench", s, s.policy_version()).size();
    }
    const double pack_seconds = Since(tp);

    std::vector<std::vector<float>> replay(K);
    for (int k = 0; k < K; ++k) replay[k] = wire::FloatValues(segments[k].actions());
    std::vector<float> replay_rewards(static_cast<size_t>(K) * steps);
    const auto t1 = Clock::now();
    for (int t = 0; t < steps; ++t) {
      for (int k = 0; k < K; ++k) {
        sim::StepResult s = envs[k]->Step(replay[k].data() + t * A, obs.data() + k * O);
        replay_rewards[k * steps + t] = static_cast<float>(s.reward);
        if (s.terminated || s.truncated) {
          envs[k]->Reset(obs.data() + k * O);
          ++f.resets;
        }
      }
    }
    const double env_seconds = Since(t1);
    // The replay must have followed the policy loop's trajectories exactly.
    for (int k = 0; k < K; ++k) {
      std::vector<float> want = wire::FloatValues(segments[k].rewards());
      if (!std::equal(want.begin(), want.end(), replay_rewards.begin() + k * steps)) {
        throw std::runtime_error("replayed environment " + std::to_string(k) +
                                 " diverged from the policy loop");
      }
    }
    const double n = static_cast<double>(K) * steps;
    with_policy.push_back(n / policy_seconds);
    env_only.push_back(n / env_seconds);
    ratio.push_back(env_seconds / policy_seconds);
    packed_ratio.push_back(env_seconds / (policy_seconds + pack_seconds));
  }
  f.with_policy = Median(with_policy);
  f.env_only = Median(env_only);
  f.ratio = Median(ratio);
  f.packed_ratio = Median(packed_ratio);
  f.bytes_per_sample = static_cast<double>(bytes) / (static_cast<double>(K) * steps * repeats);
  return f;
}

void FillWithSyntheticSegments(learner::Learner& l, int T, int O, int A, std::mt19937& rng) {
  torch::NoGradGuard no_grad;
  std::normal_distribution<float> g(0, 1);
  std::vector<float> obs((T + 1) * O), normalized(T * O), noise(T * A), rew(T);
  std::vector<uint8_t> flags(T, 0);
  while (!l.Ready()) {
    for (float& x : obs) x = g(rng);
    for (float& x : noise) x = g(rng);
    for (float& x : rew) x = 0.5f + 0.1f * g(rng);
    // Actions sampled from the learner's own policy, as an actor holding its latest weights
    // would: their importance ratios start near 1.
    l.stats().Normalize(obs.data(), T, normalized.data());
    torch::Tensor x = torch::from_blob(normalized.data(), {T, O});
    torch::Tensor act = (l.policy()->forward(x) +
                         l.policy()->log_std.exp() * torch::from_blob(noise.data(), {T, A}))
                            .contiguous();
    torch::Tensor logp = l.policy()->Evaluate(x, act).log_prob.contiguous();
    v1::TrajectorySegment s;
    s.set_policy_version(l.version());
    *s.mutable_observations() = wire::FloatTensor(obs.data(), {T + 1, O});
    *s.mutable_actions() = wire::FloatTensor(act.data_ptr<float>(), {T, A});
    *s.mutable_log_probs() = wire::FloatTensor(logp.data_ptr<float>(), {T});
    *s.mutable_rewards() = wire::FloatTensor(rew.data(), {T});
    *s.mutable_terminated() = wire::ByteTensor(flags.data(), {T});
    *s.mutable_truncated() = wire::ByteTensor(flags.data(), {T});
    *s.mutable_final_observations() = wire::FloatTensor(obs.data(), {0, O});
    l.Add(s);
  }
}

LearnerFigures MeasureLearner(const run::Experiment& e, int repeats) {
  const learner::TrainerConfig& c = e.trainer;
  const sim::EnvSpec spec = sim::MakeEnvSpec(e.environment);
  const int O = spec.observation_size, A = spec.action_size;
  const int T = c.time_horizon;
  learner::Learner l(c, O, A);
  std::mt19937 rng(1);

  LearnerFigures f;
  f.buffer = (c.buffer_size + T - 1) / T * T;
  f.minibatch = std::min(c.batch_size, f.buffer);
  const int64_t steps = c.num_epoch * (f.buffer / f.minibatch);
  learner::RawTraining raw_training(c, O, A, f.minibatch);

  std::vector<double> update, raw, ratio;
  for (int r = 0; r < repeats; ++r) {
    FillWithSyntheticSegments(l, T, O, A, rng);
    learner::UpdateStats u = l.Update();
    const double update_rate = static_cast<double>(u.samples) * c.num_epoch / u.seconds;
    const double raw_rate = raw_training.Rate(steps);
    update.push_back(update_rate);
    raw.push_back(raw_rate);
    ratio.push_back(update_rate / raw_rate);
  }
  f.update = Median(update);
  f.raw = Median(raw);
  f.ratio = Median(ratio);
  f.gflops = 6e-9 * static_cast<double>(l.trained_parameters()) * f.update;
  return f;
}

}  // namespace ragdoll::bench
