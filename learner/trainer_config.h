// The learner's hyper-parameters: the `trainer:` section, with ML-Agents' names where ML-Agents
// has one (hyperparameters.batch_size, buffer_size, learning_rate, beta, epsilon, lambd,
// num_epoch; network_settings.normalize, hidden_units, num_layers; reward_signals.extrinsic.gamma;
// max_steps, time_horizon, checkpoint_interval, keep_checkpoints).
#pragma once

#include <cstdint>
#include <string>

#include "common/network_config.h"

namespace ragdoll {
class ConfigSection;
}

namespace ragdoll::learner {

struct TrainerConfig {
  // hyperparameters
  int64_t batch_size = 1000;    // samples per minibatch (gradient step)
  int64_t buffer_size = 20000;  // samples per PPO update
  double learning_rate = 3e-4;  // the initial rate
  enum class Schedule { kLinear, kConstant, kAdaptive };
  Schedule schedule = Schedule::kLinear;  // learning_rate_schedule: linear | constant | adaptive
  double target_kl = 0.01;                // adaptive: the KL per minibatch it steers towards
  double beta = 5e-4;                     // entropy bonus
  double epsilon = 0.2;                   // surrogate clip range (also the value clip range)
  double lambd = 0.95;                    // GAE lambda
  int num_epoch = 2;                      // passes over each buffer
  double max_grad_norm = 0.5;             // global gradient-norm clip
  double value_coef = 0.5;                // weight of the value loss
  bool clip_value_loss = true;
  // network_settings
  bool normalize = true;         // observation normalisation
  bool normalize_value = false;  // the critic learns returns scaled by their running mean and std
  bool learn_log_std = true;     // false: the action noise stays at init_log_std (DeepMimic)
  NetworkConfig network;
  // reward_signals.extrinsic
  double gamma = 0.99;
  // run length and bookkeeping
  int64_t max_steps = 30'000'000;         // samples; the learning rate reaches 0 here
  int time_horizon = 64;                  // steps per trajectory segment
  int64_t checkpoint_interval = 500'000;  // samples between checkpoints
  int keep_checkpoints = 5;
  int max_policy_lag = 2;  // segments from older policy versions are dropped
  int threads = 1;         // libtorch intra-op threads
  uint64_t seed = 1;
};

TrainerConfig ReadTrainerConfig(const ConfigSection& section);

}  // namespace ragdoll::learner
