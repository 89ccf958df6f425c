#include "learner/learner.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "common/config_section.h"
#include "learner/ppo.h"

namespace ragdoll::learner {

void EpisodeStatsSum::Add(const v1::EpisodeSummary& e) {
  ++episodes;
  episode_return += e.episode_return();
  normalized_return += e.normalized_return();
  length += e.length();
  falls += e.fell() ? 1 : 0;
  rotation += e.rotation();
  velocity += e.velocity();
  end_effector += e.end_effector();
  com += e.com();
  root += e.root();
}

Learner::Learner(const TrainerConfig& config, int observation_size, int action_size)
    : config_(config),
      observation_size_(observation_size),
      action_size_(action_size),
      policy_(observation_size, action_size, config.network),
      critic_(observation_size, config.network),
      stats_(observation_size),
      adaptive_learning_rate_(config.learning_rate) {
  std::vector<torch::Tensor> params;
  for (const auto& p : policy_->parameters()) {
    if (!config.learn_log_std && p.is_same(policy_->log_std)) continue;
    params.push_back(p);
  }
  if (!config.learn_log_std) policy_->log_std.set_requires_grad(false);
  for (const auto& p : critic_->parameters()) params.push_back(p);
  optimizer_ = std::make_unique<torch::optim::Adam>(
      params, torch::optim::AdamOptions(config.learning_rate).eps(1e-5));
}

Learner::Accept Learner::Add(const v1::TrajectorySegment& segment) {
  if (segment.actions().shape(0) != config_.time_horizon) return Accept::kWrongLength;
  if (segment.policy_version() < version_ - config_.max_policy_lag) {
    ++stale_dropped_;
    return Accept::kStale;
  }
  for (const auto& e : segment.episodes()) episodes_.Add(e);
  buffered_samples_ += config_.time_horizon;
  buffer_.push_back(segment);
  return Accept::kAccepted;
}

// Exactly what actors do with the snapshot's statistics (RunningStats::Normalize); with
// normalisation off the statistics simply stay at mean 0, variance 1.
torch::Tensor Learner::Normalize(const torch::Tensor& observations) const {
  std::vector<float> mean(stats_.mean().begin(), stats_.mean().end());
  std::vector<float> var(stats_.var().begin(), stats_.var().end());
  torch::Tensor m = torch::from_blob(mean.data(), {observation_size_}).clone();
  torch::Tensor v = torch::from_blob(var.data(), {observation_size_}).clone();
  return ((observations - m) / torch::sqrt(v + 1e-8)).clamp(-10, 10);
}

// The critic's output in return units, and returns in the critic's units
// (network_settings.normalize_value); the identity when value normalisation is off.
torch::Tensor Learner::ValueFromCritic(const torch::Tensor& output) const {
  if (!config_.normalize_value) return output;
  return output * std::sqrt(return_stats_.var()[0] + 1e-8) + return_stats_.mean()[0];
}

torch::Tensor Learner::ValueToCritic(const torch::Tensor& value) const {
  if (!config_.normalize_value) return value;
  return (value - return_stats_.mean()[0]) / std::sqrt(return_stats_.var()[0] + 1e-8);
}

UpdateStats Learner::Update() {
  auto start = std::chrono::steady_clock::now();
  const int64_t N = static_cast<int64_t>(buffer_.size());
  const int64_t T = config_.time_horizon;
  const int O = observation_size_, A = action_size_;

  // Gather the buffer into [N, T(+1), ...] tensors.
  torch::Tensor obs = torch::empty({N, T + 1, O});
  torch::Tensor actions = torch::empty({N, T, A});
  torch::Tensor logprobs = torch::empty({N, T});
  torch::Tensor rewards = torch::empty({N, T});
  torch::Tensor terminated = torch::empty({N, T});
  torch::Tensor truncated = torch::empty({N, T});
  std::vector<float> finals;                          // final observations of inner truncations
  std::vector<std::pair<int64_t, int64_t>> final_at;  // their (segment, step)
  for (int64_t n = 0; n < N; ++n) {
    const auto& s = buffer_[n];
    std::memcpy(obs[n].data_ptr<float>(), s.observations().data().data(), (T + 1) * O * 4);
    std::memcpy(actions[n].data_ptr<float>(), s.actions().data().data(), T * A * 4);
    std::memcpy(logprobs[n].data_ptr<float>(), s.log_probs().data().data(), T * 4);
    std::memcpy(rewards[n].data_ptr<float>(), s.rewards().data().data(), T * 4);
    const uint8_t* term = wire::ByteData(s.terminated());
    const uint8_t* trunc = wire::ByteData(s.truncated());
    const float* fin = wire::FloatData(s.final_observations());
    int64_t k = 0;
    for (int64_t t = 0; t < T; ++t) {
      terminated[n][t] = static_cast<float>(term[t]);
      truncated[n][t] = static_cast<float>(trunc[t]);
      if (trunc[t] && t < T - 1) {
        finals.insert(finals.end(), fin + k * O, fin + (k + 1) * O);
        final_at.emplace_back(n, t);
        ++k;
      }
    }
  }

  torch::Tensor values, next_values;
  {
    torch::NoGradGuard no_grad;
    torch::Tensor all_values = ValueFromCritic(
        critic_->forward(Normalize(obs.reshape({N * (T + 1), O}))).reshape({N, T + 1}));
    values = all_values.slice(1, 0, T).contiguous();
    next_values = all_values.slice(1, 1, T + 1).clone();
    if (!final_at.empty()) {
      torch::Tensor f =
          torch::from_blob(finals.data(), {static_cast<int64_t>(final_at.size()), O}).clone();
      torch::Tensor fv = ValueFromCritic(critic_->forward(Normalize(f)));
      for (size_t i = 0; i < final_at.size(); ++i) {
        next_values[final_at[i].first][final_at[i].second] = fv[static_cast<int64_t>(i)];
      }
    }
  }
  GaeResult gae =
      ComputeGae(rewards, values, next_values, terminated, truncated, config_.gamma, config_.lambd);

  const int64_t B = N * T;
  torch::Tensor b_obs = Normalize(obs.slice(1, 0, T).reshape({B, O}));
  torch::Tensor b_actions = actions.reshape({B, A});
  torch::Tensor b_logprobs = logprobs.reshape({B});
  torch::Tensor b_advantages = gae.advantages.reshape({B});
  torch::Tensor b_returns = gae.returns.reshape({B});
  torch::Tensor b_values = values.reshape({B});
  // The critic learns (and its loss is clipped) in normalised units: the statistics take in this
  // buffer's returns first, so the targets are scaled by what they are now.
  if (config_.normalize_value) {
    torch::Tensor r = b_returns.contiguous();
    return_stats_.Update(r.data_ptr<float>(), B);
  }
  torch::Tensor b_value_targets = ValueToCritic(b_returns);
  torch::Tensor b_old_values = ValueToCritic(b_values);

  UpdateStats stats;
  using Schedule = TrainerConfig::Schedule;
  auto set_learning_rate = [this](double lr) {
    for (auto& group : optimizer_->param_groups()) {
      static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
    }
  };
  switch (config_.schedule) {
    case Schedule::kLinear:
      stats.learning_rate = LinearSchedule(config_.learning_rate, samples_, config_.max_steps);
      break;
    case Schedule::kConstant:
      stats.learning_rate = config_.learning_rate;
      break;
    case Schedule::kAdaptive:
      stats.learning_rate = adaptive_learning_rate_;
      break;
  }
  set_learning_rate(stats.learning_rate);
  PpoLossConfig loss_config;
  loss_config.clip_coef = config_.epsilon;
  loss_config.clip_vloss = config_.clip_value_loss;
  loss_config.vf_coef = config_.value_coef;
  loss_config.ent_coef = config_.beta;

  // The policy this update starts from, to measure how far each step has moved it.
  torch::Tensor old_means, old_log_std;
  {
    torch::NoGradGuard no_grad;
    old_means = policy_->forward(b_obs);
    old_log_std = policy_->log_std.detach().clone();
  }

  std::vector<torch::Tensor> params = optimizer_->param_groups()[0].params();
  int64_t minibatches = 0;
  const int64_t mb = std::min(config_.batch_size, B);
  for (int epoch = 0; epoch < config_.num_epoch; ++epoch) {
    torch::Tensor order = torch::randperm(B, torch::kLong);
    for (int64_t start_index = 0; start_index + mb <= B; start_index += mb) {
      torch::Tensor idx = order.slice(0, start_index, start_index + mb);
      auto current = policy_->Evaluate(b_obs.index_select(0, idx), b_actions.index_select(0, idx));
      const double update_kl =
          GaussianKl(old_means.index_select(0, idx), old_log_std, current.mean, policy_->log_std);
      torch::Tensor newvalue = critic_->forward(b_obs.index_select(0, idx));
      PpoLoss loss =
          ComputePpoLoss(loss_config, current.log_prob, current.entropy, newvalue,
                         b_logprobs.index_select(0, idx), b_advantages.index_select(0, idx),
                         b_value_targets.index_select(0, idx), b_old_values.index_select(0, idx));
      optimizer_->zero_grad();
      loss.loss.backward();
      double norm = torch::nn::utils::clip_grad_norm_(params, config_.max_grad_norm);
      if (!std::isfinite(norm)) {
        // A non-finite gradient never reaches the weights.
        ++stats.skipped_steps;
        continue;
      }
      optimizer_->step();
      if (config_.schedule == Schedule::kAdaptive) {
        adaptive_learning_rate_ =
            AdaptiveLearningRate(adaptive_learning_rate_, update_kl, config_.target_kl);
        set_learning_rate(adaptive_learning_rate_);
        stats.learning_rate = adaptive_learning_rate_;
      }
      stats.policy_loss += loss.pg_loss;
      stats.value_loss += loss.v_loss;
      stats.entropy += loss.entropy;
      stats.approx_kl += loss.approx_kl;
      stats.update_kl = update_kl;
      stats.clip_fraction += loss.clipfrac;
      ++minibatches;
    }
  }
  if (minibatches > 0) {
    stats.policy_loss /= minibatches;
    stats.value_loss /= minibatches;
    stats.entropy /= minibatches;
    stats.approx_kl /= minibatches;
    stats.clip_fraction /= minibatches;
  }
  stats.explained_variance = ExplainedVariance(b_values, b_returns);

  // The statistics change only after the update, so the update normalised observations exactly
  // as the actors did when they chose the actions.
  if (config_.normalize) {
    torch::Tensor seen = obs.slice(1, 0, T).reshape({B, O}).contiguous();
    stats_.Update(seen.data_ptr<float>(), B);
  }
  samples_ += B;
  stats.samples = B;
  ++version_;
  ++iterations_;
  buffer_.clear();
  buffered_samples_ = 0;
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

v1::PolicySnapshot Learner::Snapshot() { return MakeSnapshot(policy_, stats_, version_, samples_); }

namespace {

torch::Tensor DoubleTensor(const std::vector<double>& v) {
  return torch::tensor(v, torch::kFloat64);
}

std::vector<double> DoubleVector(const torch::Tensor& t) {
  torch::Tensor c = t.contiguous().to(torch::kFloat64);
  return std::vector<double>(c.data_ptr<double>(), c.data_ptr<double>() + c.numel());
}

}  // namespace

void Learner::Save(const std::string& path, const std::string& config_text) {
  torch::serialize::OutputArchive archive;
  torch::serialize::OutputArchive policy_archive, critic_archive, optimizer_archive;
  policy_->save(policy_archive);
  critic_->save(critic_archive);
  optimizer_->save(optimizer_archive);
  archive.write("policy", policy_archive);
  archive.write("critic", critic_archive);
  archive.write("optimizer", optimizer_archive);
  archive.write("stats_mean", DoubleTensor(stats_.mean()));
  archive.write("stats_var", DoubleTensor(stats_.var()));
  archive.write("stats_count", torch::tensor(stats_.count(), torch::kFloat64));
  archive.write("counters",
                torch::tensor({version_, samples_, iterations_, stale_dropped_}, torch::kInt64));
  archive.write("sizes",
                torch::tensor({int64_t{observation_size_}, int64_t{action_size_}}, torch::kInt64));
  archive.write("config", c10::IValue(config_text));
  archive.write("adaptive_learning_rate", torch::tensor(adaptive_learning_rate_, torch::kFloat64));
  archive.write("return_stats", torch::tensor({return_stats_.mean()[0], return_stats_.var()[0],
                                               return_stats_.count()},
                                              torch::kFloat64));
  std::string tmp = path + ".tmp";
  archive.save_to(tmp);
  std::filesystem::rename(tmp, path);
}

std::string Learner::Load(const std::string& path) {
  torch::serialize::InputArchive archive;
  try {
    archive.load_from(path);
    torch::Tensor sizes;
    archive.read("sizes", sizes);
    if (sizes[0].item<int64_t>() != observation_size_ || sizes[1].item<int64_t>() != action_size_) {
      throw ConfigError(path + ": checkpoint is for observation/action sizes " +
                        std::to_string(sizes[0].item<int64_t>()) + "/" +
                        std::to_string(sizes[1].item<int64_t>()) + ", this run has " +
                        std::to_string(observation_size_) + "/" + std::to_string(action_size_));
    }
    torch::serialize::InputArchive policy_archive, critic_archive, optimizer_archive;
    archive.read("policy", policy_archive);
    archive.read("critic", critic_archive);
    archive.read("optimizer", optimizer_archive);
    policy_->load(policy_archive);
    critic_->load(critic_archive);
    optimizer_->load(optimizer_archive);
    torch::Tensor mean, var, count, counters;
    archive.read("stats_mean", mean);
    archive.read("stats_var", var);
    archive.read("stats_count", count);
    archive.read("counters", counters);
    stats_ = RunningStats(DoubleVector(mean), DoubleVector(var), count.item<double>());
    version_ = counters[0].item<int64_t>();
    samples_ = counters[1].item<int64_t>();
    iterations_ = counters[2].item<int64_t>();
    stale_dropped_ = counters[3].item<int64_t>();
    // Absent from checkpoints written before the adaptive schedule: start it afresh.
    torch::Tensor adaptive;
    if (archive.try_read("adaptive_learning_rate", adaptive)) {
      adaptive_learning_rate_ = adaptive.item<double>();
    }
    // Absent from checkpoints written before value normalisation: start the statistics afresh.
    torch::Tensor returns;
    if (archive.try_read("return_stats", returns)) {
      returns = returns.contiguous();
      return_stats_ = RunningStats({returns[0].item<double>()}, {returns[1].item<double>()},
                                   returns[2].item<double>());
    }
    c10::IValue config;
    archive.read("config", config);
    return config.toStringRef();
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError(path + ": not a readable ragdoll checkpoint (" +
                      std::string(e.what()).substr(0, 200) + ")");
  }
}

void Learner::LoadWeights(const std::string& path) {
  Learner other(config_, observation_size_, action_size_);
  other.Load(path);
  torch::NoGradGuard no_grad;
  auto copy = [](torch::nn::Module& from, torch::nn::Module& to) {
    auto source = from.named_parameters();
    for (auto& item : to.named_parameters()) item.value().copy_(source[item.key()]);
  };
  copy(*other.policy_, *policy_);
  copy(*other.critic_, *critic_);
  stats_ = other.stats_;
  return_stats_ = other.return_stats_;
}

}  // namespace ragdoll::learner
