#include "learner/learner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <utility>

#include <time.h>

#include "common/config_section.h"
#include "learner/adam_step.h"
#include "learner/checkpoint_file.h"
#include "learner/collectives.h"
#include "learner/ppo.h"

namespace ragdoll::learner {
namespace {

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

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
      group_(group != nullptr ? GroupCollectives(*group) : LoneCollectives()),
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

Learner::~Learner() = default;

int Learner::replicas() const { return group_->size(); }

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

// A minibatch at a time: the whole buffer's hidden layers do not fit in the caches and ran a
// fifth slower in one piece.
torch::Tensor Learner::CriticInChunks(const torch::Tensor& observations) {
  std::vector<torch::Tensor> parts;
  const int64_t rows = observations.size(0);
  for (int64_t i = 0; i < rows; i += local_batch_size_) {
    parts.push_back(critic_->forward(observations.slice(0, i, i + local_batch_size_)));
  }
  return parts.empty() ? torch::empty({0}) : torch::cat(parts);
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
  torch::Tensor stop = torch::tensor({int64_t{stopping ? 1 : 0}}, torch::kInt64);
  group_->Sum(stop, meanwhile);
  return stop.item<int64_t>() == 0;
}

int64_t Learner::trained_parameters() const {
  int64_t n = 0;
  for (const auto& p : optimizer_->param_groups()[0].params()) n += p.numel();
  return n;
}

void Learner::SyncFromRankZero() {
  auto state = group_->FromRankZero([this] { return SaveToBytes(""); });
  if (state) LoadFromBytes(*state, "the state of learner replica 0");
}

// The buffer as tensors: N segments of T steps.
struct Learner::Rollout {
  torch::Tensor obs;                    // [N, T + 1, O]
  torch::Tensor actions;                // [N, T, A]
  torch::Tensor logprobs, rewards;      // [N, T]
  torch::Tensor terminated, truncated;  // [N, T], 0 or 1
  torch::Tensor finals;  // [F, O]: final observations of episodes truncated inside a segment
  std::vector<std::pair<int64_t, int64_t>> final_at;  // their (segment, step)
};

// The rollout flattened to B = N * T samples, with CleanRL's names.
struct Learner::Batch {
  int64_t size = 0;
  torch::Tensor b_obs;  // normalised as the actors normalised them
  torch::Tensor b_actions, b_logprobs, b_advantages, b_returns, b_values;
  // The returns and values in the critic's units (network_settings.normalize_value).
  torch::Tensor b_value_targets, b_old_values;
};

Learner::Rollout Learner::GatherBuffer() const {
  const int64_t N = static_cast<int64_t>(buffer_.size());
  const int64_t T = config_.time_horizon;
  const int O = observation_size_, A = action_size_;
  Rollout r;
  r.obs = torch::empty({N, T + 1, O});
  r.actions = torch::empty({N, T, A});
  r.logprobs = torch::empty({N, T});
  r.rewards = torch::empty({N, T});
  r.terminated = torch::empty({N, T});
  r.truncated = torch::empty({N, T});
  std::vector<float> finals;
  for (int64_t n = 0; n < N; ++n) {
    const auto& s = buffer_[n];
    std::memcpy(r.obs[n].data_ptr<float>(), s.observations().data().data(), (T + 1) * O * 4);
    std::memcpy(r.actions[n].data_ptr<float>(), s.actions().data().data(), T * A * 4);
    std::memcpy(r.logprobs[n].data_ptr<float>(), s.log_probs().data().data(), T * 4);
    std::memcpy(r.rewards[n].data_ptr<float>(), s.rewards().data().data(), T * 4);
    const uint8_t* term = wire::ByteData(s.terminated());
    const uint8_t* trunc = wire::ByteData(s.truncated());
    const float* fin = wire::FloatData(s.final_observations());
    // Through pointers: indexing a tensor element by element costs a dispatch each.
    float* terminated = r.terminated.data_ptr<float>() + n * T;
    float* truncated = r.truncated.data_ptr<float>() + n * T;
    int64_t k = 0;
    for (int64_t t = 0; t < T; ++t) {
      terminated[t] = static_cast<float>(term[t]);
      truncated[t] = static_cast<float>(trunc[t]);
      if (trunc[t] && t < T - 1) {
        finals.insert(finals.end(), fin + k * O, fin + (k + 1) * O);
        r.final_at.emplace_back(n, t);
        ++k;
      }
    }
  }
  if (!r.final_at.empty()) {
    r.finals =
        torch::from_blob(finals.data(), {static_cast<int64_t>(r.final_at.size()), O}).clone();
  }
  return r;
}

Learner::Batch Learner::ComputeAdvantages(const Rollout& r) {
  const int64_t N = r.obs.size(0), T = config_.time_horizon;
  const int O = observation_size_, A = action_size_;
  torch::Tensor values, next_values;
  {
    torch::NoGradGuard no_grad;
    torch::Tensor all_values =
        ValueFromCritic(CriticInChunks(Normalize(r.obs.reshape({N * (T + 1), O}))))
            .reshape({N, T + 1});
    values = all_values.slice(1, 0, T).contiguous();
    next_values = all_values.slice(1, 1, T + 1).clone();
    if (!r.final_at.empty()) {
      torch::Tensor fv = ValueFromCritic(critic_->forward(Normalize(r.finals)));
      for (size_t i = 0; i < r.final_at.size(); ++i) {
        next_values[r.final_at[i].first][r.final_at[i].second] = fv[static_cast<int64_t>(i)];
      }
    }
  }
  GaeResult gae = ComputeGae(r.rewards, values, next_values, r.terminated, r.truncated,
                             config_.gamma, config_.lambd);

  Batch b;
  const int64_t B = b.size = N * T;
  b.b_obs = Normalize(r.obs.slice(1, 0, T).reshape({B, O}));
  b.b_actions = r.actions.reshape({B, A});
  b.b_logprobs = r.logprobs.reshape({B});
  b.b_advantages = gae.advantages.reshape({B});
  b.b_returns = gae.returns.reshape({B});
  b.b_values = values.reshape({B});
  // The critic learns (and its loss is clipped) in normalised units: the statistics take in this
  // buffer's returns first, so the targets are scaled by what they are now.
  if (config_.normalize_value) group_->MergeStatistics(return_stats_, b.b_returns.reshape({B, 1}));
  b.b_value_targets = ValueToCritic(b.b_returns);
  b.b_old_values = ValueToCritic(b.b_values);
  return b;
}

double Learner::ScheduledLearningRate() const {
  switch (config_.schedule) {
    case TrainerConfig::Schedule::kLinear:
      return LinearSchedule(config_.learning_rate, samples_, config_.max_steps);
    case TrainerConfig::Schedule::kConstant:
      return config_.learning_rate;
    case TrainerConfig::Schedule::kAdaptive:
      return adaptive_learning_rate_;
  }
  return config_.learning_rate;
}

void Learner::SetLearningRate(double learning_rate) {
  for (auto& group : optimizer_->param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(learning_rate);
  }
}

bool Learner::MinibatchStep(const Batch& b, const torch::Tensor& mb_inds,
                            const torch::Tensor& mb_advantages, const OldPolicy& old,
                            bool measure_kl, UpdateStats& stats) {
  PpoLossConfig loss_config;
  loss_config.clip_coef = config_.epsilon;
  loss_config.clip_vloss = config_.clip_value_loss;
  loss_config.vf_coef = config_.value_coef;
  loss_config.ent_coef = config_.beta;
  loss_config.norm_adv = false;  // normalised over the group's minibatch already

  const torch::Tensor mb_obs = b.b_obs.index_select(0, mb_inds);
  auto current = policy_->Evaluate(mb_obs, b.b_actions.index_select(0, mb_inds));
  double update_kl = 0;
  if (measure_kl) {
    const torch::Tensor old_means = old.all_rows ? old.means.index_select(0, mb_inds) : old.means;
    update_kl = GaussianKl(old_means, old.log_std, current.mean, policy_->log_std);
  }
  torch::Tensor newvalue = critic_->forward(mb_obs);
  PpoLoss loss = ComputePpoLoss(loss_config, current.log_prob, current.entropy, newvalue,
                                b.b_logprobs.index_select(0, mb_inds), mb_advantages,
                                b.b_value_targets.index_select(0, mb_inds),
                                b.b_old_values.index_select(0, mb_inds));
  update_kl = group_->Backward(*optimizer_, loss.loss, update_kl);
  const std::vector<torch::Tensor>& params = optimizer_->param_groups()[0].params();
  double norm = torch::nn::utils::clip_grad_norm_(params, config_.max_grad_norm);
  if (!std::isfinite(norm)) {
    // A non-finite gradient never reaches the weights.
    ++stats.skipped_steps;
    return false;
  }
  AdamStep(*optimizer_);
  if (config_.schedule == TrainerConfig::Schedule::kAdaptive) {
    adaptive_learning_rate_ =
        AdaptiveLearningRate(adaptive_learning_rate_, update_kl, config_.target_kl);
    SetLearningRate(adaptive_learning_rate_);
    stats.learning_rate = adaptive_learning_rate_;
  }
  stats.policy_loss += loss.pg_loss;
  stats.value_loss += loss.v_loss;
  stats.entropy += loss.entropy;
  stats.approx_kl += loss.approx_kl;
  stats.update_kl = update_kl;
  stats.clip_fraction += loss.clipfrac;
  return true;
}

void Learner::FinishStatistics(const Batch& b, int64_t minibatches, double weight,
                               UpdateStats& stats) {
  if (minibatches > 0) {
    stats.policy_loss /= minibatches;
    stats.value_loss /= minibatches;
    stats.entropy /= minibatches;
    stats.approx_kl /= minibatches;
    stats.clip_fraction /= minibatches;
  }
  stats.explained_variance = ExplainedVariance(b.b_values, b.b_returns);
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

int64_t Learner::SumEpisodesOverGroup(int64_t samples) {
  EpisodeStatsSum& e = episodes_;
  std::vector<double> local = {static_cast<double>(samples),
                               static_cast<double>(e.episodes),
                               e.episode_return,
                               e.normalized_return,
                               e.length,
                               e.falls};
  local.insert(local.end(), e.figures.begin(), e.figures.end());
  torch::Tensor sums = torch::tensor(local, torch::kFloat64);
  group_->Sum(sums);
  e.episodes = static_cast<int64_t>(sums[1].item<double>());
  double* fields[] = {&e.episode_return, &e.normalized_return, &e.length, &e.falls};
  for (int i = 0; i < 4; ++i) *fields[i] = sums[2 + i].item<double>();
  for (size_t i = 0; i < e.figures.size(); ++i) e.figures[i] = sums[6 + i].item<double>();
  return static_cast<int64_t>(sums[0].item<double>());
}

int64_t Learner::NextVersion() {
  // Numbering continues above any version an actor already runs (this learner resumed from an
  // older checkpoint); every replica takes the group's newest.
  torch::Tensor negated = torch::tensor({-std::max(version_, newest_seen_)}, torch::kInt64);
  group_->Min(negated);
  return -negated[0].item<int64_t>() + 1;
}

UpdateStats Learner::Update() {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ProcessCpuSeconds();
  const Rollout rollout = GatherBuffer();
  const Batch b = ComputeAdvantages(rollout);

  UpdateStats stats;
  stats.learning_rate = ScheduledLearningRate();
  SetLearningRate(stats.learning_rate);
  const Minibatches minibatches = group_->Split(b.size, local_batch_size_);
  // Every epoch's order is drawn up front, so that the minibatches whose distance from the
  // starting policy is needed are known before the policy moves.
  std::vector<torch::Tensor> orders;
  for (int epoch = 0; epoch < config_.num_epoch; ++epoch) {
    orders.push_back(torch::randperm(b.size, torch::kLong));
  }
  auto minibatch = [&](int epoch, int64_t step) {
    return orders[epoch].slice(0, step * minibatches.size, (step + 1) * minibatches.size);
  };
  // The adaptive schedule steers by every step's distance from the starting policy; otherwise
  // only the last step's is reported, and the starting policy's means are needed for its
  // minibatch alone (a forward pass over the whole batch is most of the rest of an update).
  const bool adaptive = config_.schedule == TrainerConfig::Schedule::kAdaptive;
  const int last_epoch = config_.num_epoch - 1;
  const int64_t last_step = minibatches.steps - 1;
  OldPolicy old;
  if (last_step >= 0) {
    torch::NoGradGuard no_grad;
    old.all_rows = adaptive;
    old.means = policy_->forward(
        adaptive ? b.b_obs : b.b_obs.index_select(0, minibatch(last_epoch, last_step)));
    old.log_std = policy_->log_std.detach().clone();
  }

  int64_t steps_taken = 0;
  for (int epoch = 0; epoch < config_.num_epoch; ++epoch) {
    group_->StartEpoch(b.b_advantages, orders[epoch]);
    for (int64_t step = 0; step < minibatches.steps; ++step) {
      const torch::Tensor mb_inds = minibatch(epoch, step);
      const torch::Tensor mb_advantages =
          group_->NormalizedAdvantages(b.b_advantages.index_select(0, mb_inds), step);
      const bool measure_kl = adaptive || (epoch == last_epoch && step == last_step);
      if (MinibatchStep(b, mb_inds, mb_advantages, old, measure_kl, stats)) ++steps_taken;
    }
  }
  FinishStatistics(b, steps_taken, minibatches.weight, stats);
  stats.gflop = 6e-9 * static_cast<double>(trained_parameters()) *
                static_cast<double>(steps_taken * minibatches.size);

  // The statistics change only after the update, so the update normalised observations exactly
  // as the actors did when they chose the actions.
  const int64_t T = config_.time_horizon;
  if (config_.normalize) {
    group_->MergeStatistics(stats_,
                            rollout.obs.slice(1, 0, T).reshape({b.size, observation_size_}));
  }
  stats.samples = SumEpisodesOverGroup(b.size);
  samples_ += stats.samples;
  version_ = NextVersion();
  ++iterations_;
  buffer_.clear();
  buffered_samples_ = 0;
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats.cpu_seconds = ProcessCpuSeconds() - cpu_start;
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

namespace {

torch::serialize::InputArchive ReadArchive(const std::string& path) {
  torch::serialize::InputArchive archive;
  try {
    std::istringstream in(ReadCheckpointFile(path));
    archive.load_from(in);
  } catch (const std::exception& e) {
    throw Unreadable(path, e);
  }
  return archive;
}

}  // namespace

std::pair<int, int> CheckpointSizes(const std::string& path) {
  torch::serialize::InputArchive archive = ReadArchive(path);
  torch::Tensor sizes;
  try {
    archive.read("sizes", sizes);
  } catch (const std::exception& e) {
    throw Unreadable(path, e);
  }
  return {static_cast<int>(sizes[0].item<int64_t>()), static_cast<int>(sizes[1].item<int64_t>())};
}

void Learner::LoadWeights(const std::string& path) {
  const auto [observations, actions] = CheckpointSizes(path);
  if (actions != action_size_ || observations > observation_size_) {
    throw ConfigError(path + ": checkpoint is for observation/action sizes " +
                      std::to_string(observations) + "/" + std::to_string(actions) +
                      ", this run has " + std::to_string(observation_size_) + "/" +
                      std::to_string(action_size_) +
                      " (a run can start from one whose observation its own extends)");
  }
  // The networks and statistics only: the source's optimizer may have trained other parameters
  // (learn_log_std) and is not wanted.
  GaussianPolicy policy(observations, actions, config_.network);
  ValueNetwork critic(observations, config_.network);
  torch::serialize::InputArchive archive = ReadArchive(path);
  std::vector<double> mean, var;
  double count = 0;
  try {
    torch::serialize::InputArchive policy_archive, critic_archive;
    archive.read("policy", policy_archive);
    archive.read("critic", critic_archive);
    policy->load(policy_archive);
    critic->load(critic_archive);
    torch::Tensor m, v, c, returns;
    archive.read("stats_mean", m);
    archive.read("stats_var", v);
    archive.read("stats_count", c);
    mean = DoubleVector(m);
    var = DoubleVector(v);
    count = c.item<double>();
    if (archive.try_read("return_stats", returns)) {
      returns = returns.contiguous();
      return_stats_ = RunningStats({returns[0].item<double>()}, {returns[1].item<double>()},
                                   returns[2].item<double>());
    }
  } catch (const std::exception& e) {
    throw Unreadable(path, e);
  }
  torch::NoGradGuard no_grad;
  // Every weight as it was; the first layers' columns for observation entries the source did not
  // have start at zero, so the networks compute what the source's did.
  auto copy = [](torch::nn::Module& from, torch::nn::Module& to) {
    auto source = from.named_parameters();
    for (auto& item : to.named_parameters()) {
      const torch::Tensor& value = source[item.key()];
      if (value.sizes() == item.value().sizes()) {
        item.value().copy_(value);
      } else {
        item.value().zero_();
        item.value().narrow(1, 0, value.size(1)).copy_(value);
      }
    }
  };
  copy(*policy, *policy_);
  copy(*critic, *critic_);
  mean.resize(observation_size_, 0.0);
  var.resize(observation_size_, 1.0);
  stats_ = RunningStats(std::move(mean), std::move(var), count);
}

}  // namespace ragdoll::learner
