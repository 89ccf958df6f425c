#include "learner/learner.h"

#include "learner/checkpoint_file.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <utility>

#include "common/config_section.h"
#include "learner/checkpoint_file.h"
#include "learner/ppo.h"

namespace ragdoll::learner {

void EpisodeStatsSum::Add(const v1::EpisodeSummary& e) {
  ++episodes;
  episode_return += e.episode_return();
  normalized_return += e.normalized_return();
  length += e.length();
  falls += e.fell() ? 1 : 0;
  for (int i = 0; i < e.figures_size(); ++i) {
    const v1::Figure& f = e.figures(i);
    // Actors send the figures in the spec's order: look further only when they do not.
    size_t k = static_cast<size_t>(i);
    if (k >= figure_names.size() || figure_names[k] != f.name()) {
      k = std::find(figure_names.begin(), figure_names.end(), f.name()) - figure_names.begin();
    }
    if (k < figures.size()) figures[k] += f.value();
  }
}

Learner::Learner(const TrainerConfig& config, int observation_size, int action_size,
                 ReplicaGroup* group)
    : config_(config),
      observation_size_(observation_size),
      action_size_(action_size),
      group_(group),
      local_buffer_size_((config.buffer_size + replicas() - 1) / replicas()),
      local_batch_size_(std::max<int64_t>(1, config.batch_size / replicas())),
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

Learner::Accept Learner::Add(v1::TrajectorySegment segment) {
  if (segment.actions().shape(0) != config_.time_horizon) return Accept::kWrongLength;
  if (segment.policy_version() < version_ - config_.max_policy_lag ||
      segment.policy_version() > version_ + kMaxVersionAhead) {
    ++stale_dropped_;
    return Accept::kStale;
  }
  newest_seen_ = std::max(newest_seen_, segment.policy_version());
  for (const auto& e : segment.episodes()) episodes_.Add(e);
  buffered_samples_ += config_.time_horizon;
  buffer_.push_back(std::move(segment));
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

bool Learner::AgreeToUpdate(bool stopping, const std::function<void()>& meanwhile) {
  if (group_ == nullptr) return !stopping;
  torch::Tensor stop = torch::tensor({int64_t{stopping ? 1 : 0}}, torch::kInt64);
  group_->Sum(stop, meanwhile);
  return stop.item<int64_t>() == 0;
}

void Learner::MergeStatistics(RunningStats& stats, const torch::Tensor& rows) {
  torch::Tensor x = rows.contiguous();
  if (group_ == nullptr) {
    stats.Update(x.data_ptr<float>(), x.size(0));
    return;
  }
  // Each replica's own moments, then the union's (Chan et al.): its mean from the counts and
  // sums, then its squared deviations as each replica's plus its mean's distance from the union's.
  const int size = stats.size();
  const double n = static_cast<double>(x.size(0));
  RunningStats::Moments local = RunningStats::BatchMoments(x.data_ptr<float>(), x.size(0), size);
  torch::Tensor sums = torch::empty({size + 1}, torch::kFloat64);
  double* s = sums.data_ptr<double>();
  s[0] = n;
  for (int j = 0; j < size; ++j) s[1 + j] = n * local.mean[j];
  group_->Sum(sums);
  const double count = s[0];
  if (count <= 0) return;
  std::vector<double> mean(size);
  for (int j = 0; j < size; ++j) mean[j] = s[1 + j] / count;
  torch::Tensor m2 = torch::empty({size}, torch::kFloat64);
  double* m = m2.data_ptr<double>();
  for (int j = 0; j < size; ++j) {
    const double d = local.mean[j] - mean[j];
    m[j] = local.m2[j] + n * d * d;
  }
  group_->Sum(m2);
  stats.Merge(count, mean, std::vector<double>(m, m + size));
}

int64_t Learner::trained_parameters() const {
  int64_t n = 0;
  for (const auto& p : optimizer_->param_groups()[0].params()) n += p.numel();
  return n;
}

void Learner::ViewGradientsInGroupBuffer(const std::vector<torch::Tensor>& params) {
  const int64_t total = trained_parameters() + 1;  // and the KL slot
  bool viewing = group_gradients_.defined() && group_gradients_.numel() == total;
  float* base = viewing ? group_gradients_.data_ptr<float>() : nullptr;
  int64_t offset = 0;
  for (const auto& p : params) {
    viewing = viewing && p.grad().defined() && p.grad().data_ptr<float>() == base + offset;
    offset += p.numel();
  }
  if (viewing) return;
  group_gradients_ = torch::zeros({total}, torch::kFloat32);
  offset = 0;
  for (const auto& p : params) {
    const int64_t n = p.numel();
    torch::Tensor view = group_gradients_.slice(0, offset, offset + n).view_as(p);
    if (p.grad().defined()) view.copy_(p.grad());
    p.mutable_grad() = view;
    offset += n;
  }
}

void Learner::SyncFromRankZero() {
  if (group_ == nullptr) return;
  std::string state = group_->Broadcast(group_->rank() == 0 ? SaveToBytes("") : std::string());
  if (group_->rank() != 0) LoadFromBytes(state, "the state of learner replica 0");
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
  if (config_.normalize_value) MergeStatistics(return_stats_, b_returns.reshape({B, 1}));
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
  // Replicas normalise each minibatch's advantages by the whole group's minibatch (below).
  loss_config.norm_adv = group_ == nullptr;

  // The policy this update starts from, to measure how far each step has moved it.
  torch::Tensor old_means, old_log_std;
  {
    torch::NoGradGuard no_grad;
    old_means = policy_->forward(b_obs);
    old_log_std = policy_->log_std.detach().clone();
  }

  std::vector<torch::Tensor> params = optimizer_->param_groups()[0].params();
  int64_t minibatches = 0;
  int64_t mb = std::min(local_batch_size_, B);
  // Every replica takes the same number of gradient steps. A replica that holds more than its
  // share (it took segments while waiting for the others) takes larger minibatches, and its
  // gradient weighs by its minibatch's part of the group's: the group's step is the mean over
  // the union of the replicas' minibatches, as one learner's would be.
  torch::Tensor steps = torch::tensor({B / mb}, torch::kInt64);
  if (group_ != nullptr) group_->Min(steps);
  const int64_t steps_per_epoch = steps.item<int64_t>();
  double weight = 1;  // this replica's share of the group's minibatch
  if (group_ != nullptr) {
    mb = B / steps_per_epoch;
    torch::Tensor group_mb = torch::tensor({mb}, torch::kInt64);
    group_->Sum(group_mb);
    weight = static_cast<double>(mb) / static_cast<double>(group_mb.item<int64_t>());
  }
  for (int epoch = 0; epoch < config_.num_epoch; ++epoch) {
    torch::Tensor order = torch::randperm(B, torch::kLong);
    // The group's minibatch is the union of the replicas' ones: each step normalises its
    // advantages by that union's mean and (unbiased) standard deviation, as one learner would.
    // The advantages stay fixed through the update, so one collective per epoch carries every
    // step's moments (sum, sum of squares, count; float64).
    torch::Tensor moments;
    if (group_ != nullptr) {
      torch::Tensor a = b_advantages.index_select(0, order.slice(0, 0, steps_per_epoch * mb))
                            .to(torch::kFloat64)
                            .reshape({steps_per_epoch, mb});
      moments =
          torch::stack({a.sum(1), a.pow(2).sum(1),
                        torch::full({steps_per_epoch}, static_cast<double>(mb), torch::kFloat64)},
                       1)
              .contiguous();
      group_->Sum(moments);
    }
    for (int64_t step = 0; step < steps_per_epoch; ++step) {
      torch::Tensor idx = order.slice(0, step * mb, (step + 1) * mb);
      auto current = policy_->Evaluate(b_obs.index_select(0, idx), b_actions.index_select(0, idx));
      double update_kl =
          GaussianKl(old_means.index_select(0, idx), old_log_std, current.mean, policy_->log_std);
      torch::Tensor newvalue = critic_->forward(b_obs.index_select(0, idx));
      torch::Tensor advantages = b_advantages.index_select(0, idx);
      if (group_ != nullptr) {
        const double* m = moments.data_ptr<double>() + 3 * step;
        const double n = m[2];
        const double mean = m[0] / n;
        const double var = n > 1 ? std::max(0.0, (m[1] - n * mean * mean) / (n - 1)) : 0.0;
        if (n > 1) advantages = (advantages - mean) / (std::sqrt(var) + 1e-8);
      }
      PpoLoss loss = ComputePpoLoss(
          loss_config, current.log_prob, current.entropy, newvalue, b_logprobs.index_select(0, idx),
          advantages, b_value_targets.index_select(0, idx), b_old_values.index_select(0, idx));
      if (group_ == nullptr) {
        optimizer_->zero_grad();
        loss.loss.backward();
      } else {
        // One all-reduce per step, on the gradients in place: every gradient and this step's
        // KL, each weighted by this replica's share first, so their sum is the group's mean.
        // Overlapping it with the backward pass measured slower on pinned cores, both by hand
        // (the critic's bucket) and with DDP's own c10d::Reducer: the transfer takes the same
        // core (docs/learner-scaling.md).
        ViewGradientsInGroupBuffer(params);
        group_gradients_.zero_();
        (loss.loss * weight).backward();
        float* kl_slot = group_gradients_.data_ptr<float>() + group_gradients_.numel() - 1;
        *kl_slot = static_cast<float>(update_kl * weight);
        group_->Sum(group_gradients_);
        update_kl = *kl_slot;
      }
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
  if (group_ != nullptr) {
    // The group's means of what each replica measured on its share, weighted as its gradients.
    torch::Tensor reported =
        torch::tensor({stats.policy_loss, stats.value_loss, stats.entropy, stats.approx_kl,
                       stats.clip_fraction, stats.explained_variance},
                      torch::kFloat64)
            .mul_(weight);
    group_->Sum(reported);
    stats.policy_loss = reported[0].item<double>();
    stats.value_loss = reported[1].item<double>();
    stats.entropy = reported[2].item<double>();
    stats.approx_kl = reported[3].item<double>();
    stats.clip_fraction = reported[4].item<double>();
    stats.explained_variance = reported[5].item<double>();
  }

  // The statistics change only after the update, so the update normalised observations exactly
  // as the actors did when they chose the actions.
  if (config_.normalize) MergeStatistics(stats_, obs.slice(1, 0, T).reshape({B, O}));
  int64_t group_samples = B;
  if (group_ != nullptr) {
    EpisodeStatsSum& e = episodes_;
    std::vector<double> local = {static_cast<double>(B),
                                 static_cast<double>(e.episodes),
                                 e.episode_return,
                                 e.normalized_return,
                                 e.length,
                                 e.falls};
    local.insert(local.end(), e.figures.begin(), e.figures.end());
    torch::Tensor sums = torch::tensor(local, torch::kFloat64);
    group_->Sum(sums);
    group_samples = static_cast<int64_t>(sums[0].item<double>());
    e.episodes = static_cast<int64_t>(sums[1].item<double>());
    double* fields[] = {&e.episode_return, &e.normalized_return, &e.length, &e.falls};
    for (int i = 0; i < 4; ++i) *fields[i] = sums[2 + i].item<double>();
    for (size_t i = 0; i < e.figures.size(); ++i) e.figures[i] = sums[6 + i].item<double>();
  }
  samples_ += group_samples;
  stats.samples = group_samples;
  // Numbering continues above any version an actor already runs (this learner resumed from an
  // older checkpoint); every replica takes the group's newest.
  int64_t next = std::max(version_, newest_seen_);
  if (group_ != nullptr) {
    torch::Tensor negated = torch::tensor({-next}, torch::kInt64);
    group_->Min(negated);
    next = -negated[0].item<int64_t>();
  }
  version_ = next + 1;
  ++iterations_;
  buffer_.clear();
  buffered_samples_ = 0;
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

void Learner::ContinueNumberingFrom(int64_t version) { version_ = std::max(version_, version); }

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

void Learner::SaveArchive(torch::serialize::OutputArchive& archive, const std::string& config_text,
                          bool with_optimizer) {
  torch::serialize::OutputArchive policy_archive, critic_archive, optimizer_archive;
  policy_->save(policy_archive);
  critic_->save(critic_archive);
  archive.write("policy", policy_archive);
  archive.write("critic", critic_archive);
  if (with_optimizer) {
    optimizer_->save(optimizer_archive);
    archive.write("optimizer", optimizer_archive);
  }
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
}

void Learner::Save(const std::string& path, const std::string& config_text) {
  WriteCheckpointFile(path, SaveToBytes(config_text));
}

std::string Learner::SaveToBytes(const std::string& config_text, bool with_optimizer) {
  torch::serialize::OutputArchive archive;
  SaveArchive(archive, config_text, with_optimizer);
  std::ostringstream out;
  archive.save_to(out);
  return out.str();
}

namespace {

ConfigError Unreadable(const std::string& source, const std::exception& e) {
  return ConfigError(source + ": not a readable ragdoll checkpoint (" +
                     std::string(e.what()).substr(0, 200) + ")");
}

}  // namespace

std::string Learner::Load(const std::string& path) {
  std::string payload;
  try {
    payload = ReadCheckpointFile(path);
  } catch (const std::exception& e) {
    throw ConfigError(e.what());
  }
  return LoadFromBytes(payload, path);
}

std::string Learner::LoadFromBytes(const std::string& bytes, const std::string& source) {
  torch::serialize::InputArchive archive;
  try {
    std::istringstream in(bytes);
    archive.load_from(in);
  } catch (const std::exception& e) {
    throw Unreadable(source, e);
  }
  return LoadArchive(archive, source);
}

std::string Learner::LoadArchive(torch::serialize::InputArchive& archive, const std::string& path) {
  try {
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
    policy_->load(policy_archive);
    critic_->load(critic_archive);
    // Absent from a shipped checkpoint (`export --run`): the optimizer starts afresh.
    optimizer_restored_ = archive.try_read("optimizer", optimizer_archive);
    if (optimizer_restored_) optimizer_->load(optimizer_archive);
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
    throw Unreadable(path, e);
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
