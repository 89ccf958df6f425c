#include "actor/rollout.h"

#include <cmath>
#include <stdexcept>

#include "common/policy.h"
#include "sim/motion_set.h"
#include "sim/steering_task.h"

namespace ragdoll::actor {
namespace {

constexpr double kLogSqrt2Pi = 0.91893853320467274178;

v1::EpisodeSummary Summary(const sim::EnvSpec& spec, const sim::EpisodeStats& e) {
  v1::EpisodeSummary s;
  s.set_episode_return(e.episode_return);
  s.set_length(e.length);
  s.set_normalized_return(e.normalized_return);
  s.set_fell(e.fell());
  for (size_t i = 0; i < e.figures.size(); ++i) {
    v1::Figure* f = s.add_figures();
    f->set_name(spec.figure_names[i]);
    f->set_value(e.figures[i]);
  }
  return s;
}

}  // namespace

void SetPolicyThreads(int threads) { at::set_num_threads(threads); }

RolloutWorker::RolloutWorker(const sim::EnvConfig& config, int environments, int time_horizon,
                             uint64_t seed, std::string actor_id, const TaskFactory& make_task)
    : time_horizon_(time_horizon), actor_id_(std::move(actor_id)), noise_(seed * 7919 + 1) {
  auto character = character::Character::Load(config.character, config.physics_dt());
  auto motions = sim::LoadMotionSet(config, *character);
  sim::EnvConfig resolved = config;
  sim::ResolveAllowedContacts(*motions, *character, &resolved);
  for (int i = 0; i < environments; ++i) {
    envs_.push_back(std::make_unique<sim::ImitationEnv>(character, motions, resolved, seed + i,
                                                        make_task ? make_task() : nullptr));
  }
  const int O = spec().observation_size;
  observations_.resize(static_cast<size_t>(environments) * O);
  normalized_.resize(observations_.size());
  stats_ = RunningStats(O);
  for (int i = 0; i < environments; ++i) envs_[i]->Reset(observations_.data() + i * O);
}

void RolloutWorker::SetPolicy(const v1::PolicySnapshot& snapshot) {
  if (snapshot.network().observation_size() != spec().observation_size ||
      snapshot.network().action_size() != spec().action_size) {
    throw std::invalid_argument("snapshot is for observation/action sizes " +
                                std::to_string(snapshot.network().observation_size()) + "/" +
                                std::to_string(snapshot.network().action_size()) +
                                ", the environment has " + std::to_string(spec().observation_size) +
                                "/" + std::to_string(spec().action_size));
  }
  GaussianPolicy current(policy_);
  if (policy_ == nullptr || !LoadSnapshotWeights(snapshot, current)) {
    policy_ = PolicyFromSnapshot(snapshot).ptr();
  }
  stats_ = StatsFromSnapshot(snapshot);
  log_std_ = wire::FloatValues(snapshot.log_std());
  policy_version_ = snapshot.version();
}

void RolloutWorker::Act(bool deterministic, std::vector<float>* actions,
                        std::vector<float>* log_probs) {
  const int K = environments(), O = spec().observation_size, A = spec().action_size;
  stats_.Normalize(observations_.data(), K, normalized_.data());
  torch::Tensor mean;
  {
    torch::InferenceMode inference;
    mean = policy_->forward(torch::from_blob(normalized_.data(), {K, O})).contiguous();
  }
  const float* mu = mean.data_ptr<float>();
  actions->resize(static_cast<size_t>(K) * A);
  log_probs->assign(K, 0.0f);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  for (int k = 0; k < K; ++k) {
    double log_prob = 0;
    for (int a = 0; a < A; ++a) {
      const int i = k * A + a;
      const float sigma = std::exp(log_std_[a]);
      float action = deterministic ? mu[i] : mu[i] + sigma * static_cast<float>(gaussian(noise_));
      (*actions)[i] = action;
      // The same formula, in the same float precision, as the learner's log-probability.
      float z = (action - mu[i]) * std::exp(-log_std_[a]);
      log_prob += -0.5 * z * z - log_std_[a] - kLogSqrt2Pi;
    }
    (*log_probs)[k] = static_cast<float>(log_prob);
  }
}

sim::EpisodeStats RolloutWorker::RunEpisode(bool deterministic) {
  std::vector<float> actions, log_probs;
  envs_[0]->Reset(observations_.data());
  for (;;) {
    Act(deterministic, &actions, &log_probs);
    sim::StepResult r = envs_[0]->Step(actions.data(), observations_.data());
    if (r.terminated || r.truncated) break;
  }
  sim::EpisodeStats stats = envs_[0]->episode();
  envs_[0]->Reset(observations_.data());
  return stats;
}

sim::StepResult RolloutWorker::StepFirst(bool deterministic) {
  std::vector<float> actions, log_probs;
  Act(deterministic, &actions, &log_probs);
  return envs_[0]->Step(actions.data(), observations_.data());
}

void RolloutWorker::ResetFirst(double phase) {
  envs_[0]->ResetAtPhase(phase, observations_.data());
}

void RolloutWorker::SetCommandFirst(int entry) {
  sim::Steering(*envs_[0]).SetCommand(*envs_[0], entry);
  envs_[0]->Observe(observations_.data());
}

void RolloutWorker::SetStateFirst(const double* qpos, const double* qvel) {
  envs_[0]->SetState(qpos, qvel);
  envs_[0]->Observe(observations_.data());
}

std::vector<v1::TrajectorySegment> RolloutWorker::Collect() {
  if (!has_policy()) throw std::logic_error("Collect() before SetPolicy()");
  const int K = environments(), O = spec().observation_size, A = spec().action_size;
  const int T = time_horizon_;
  std::vector<std::vector<float>> obs(K), act(K), logp(K), rew(K), finals(K);
  std::vector<std::vector<uint8_t>> term(K), trunc(K);
  std::vector<std::vector<v1::EpisodeSummary>> episodes(K);
  for (int k = 0; k < K; ++k) {
    obs[k].reserve(static_cast<size_t>(T + 1) * O);
    act[k].reserve(static_cast<size_t>(T) * A);
  }
  std::vector<float> actions, log_probs;
  for (int t = 0; t < T; ++t) {
    Act(false, &actions, &log_probs);
    for (int k = 0; k < K; ++k) {
      float* o = observations_.data() + k * O;
      obs[k].insert(obs[k].end(), o, o + O);
      act[k].insert(act[k].end(), actions.begin() + k * A, actions.begin() + (k + 1) * A);
      logp[k].push_back(log_probs[k]);
      sim::StepResult r = envs_[k]->Step(actions.data() + k * A, o);
      rew[k].push_back(static_cast<float>(r.reward));
      term[k].push_back(r.terminated ? 1 : 0);
      trunc[k].push_back(r.truncated ? 1 : 0);
      if (r.terminated || r.truncated) {
        episodes[k].push_back(Summary(spec(), envs_[k]->episode()));
        // The segment's bootstrap row (after the last step) or an inner truncation's final
        // observation is the one before the reset.
        if (t == T - 1) {
          obs[k].insert(obs[k].end(), o, o + O);
        } else if (r.truncated) {
          finals[k].insert(finals[k].end(), o, o + O);
        }
        envs_[k]->Reset(o);
      } else if (t == T - 1) {
        obs[k].insert(obs[k].end(), o, o + O);
      }
    }
  }
  samples_ += static_cast<int64_t>(K) * T;
  std::vector<v1::TrajectorySegment> segments(K);
  for (int k = 0; k < K; ++k) {
    v1::TrajectorySegment& s = segments[k];
    s.set_actor_id(actor_id_);
    s.set_env_index(k);
    s.set_policy_version(policy_version_);
    *s.mutable_observations() = wire::FloatTensor(obs[k].data(), {T + 1, O});
    *s.mutable_actions() = wire::FloatTensor(act[k].data(), {T, A});
    *s.mutable_log_probs() = wire::FloatTensor(logp[k].data(), {T});
    *s.mutable_rewards() = wire::FloatTensor(rew[k].data(), {T});
    *s.mutable_terminated() = wire::ByteTensor(term[k].data(), {T});
    *s.mutable_truncated() = wire::ByteTensor(trunc[k].data(), {T});
    *s.mutable_final_observations() =
        wire::FloatTensor(finals[k].data(), {static_cast<int64_t>(finals[k].size()) / O, O});
    for (auto& e : episodes[k]) *s.add_episodes() = e;
  }
  return segments;
}

}  // namespace ragdoll::actor
