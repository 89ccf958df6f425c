#include "learner/trainer_config.h"

#include <cmath>
#include <limits>

#include "common/config_section.h"

namespace ragdoll::learner {
namespace {

double PositiveNumber(const ConfigSection& s, const std::string& key, double fallback) {
  double v = s.Get<double>(key, fallback);
  if (!std::isfinite(v) || v <= 0) s.Fail(key, "must be a positive number");
  return v;
}

double Fraction(const ConfigSection& s, const std::string& key, double fallback) {
  double v = s.Get<double>(key, fallback);
  if (!(v >= 0 && v <= 1)) s.Fail(key, "must be in [0, 1]");
  return v;
}

// A whole number in [low, high]. Accepts 3e7 as well as 30000000: YAML users write both. The
// default ceiling, 1e15, keeps every such count exact in a double and far from int64's limit
// (fuzz_config found 4e36 cast to int64: undefined behaviour).
int64_t AtLeast(const ConfigSection& s, const std::string& key, int64_t fallback, int64_t low,
                int64_t high = 1'000'000'000'000'000) {
  double v = s.Get<double>(key, static_cast<double>(fallback));
  if (!std::isfinite(v) || v < static_cast<double>(low) || v != std::floor(v)) {
    s.Fail(key, "must be a whole number of at least " + std::to_string(low));
  }
  if (v > static_cast<double>(high)) {
    s.Fail(key, "must be at most " + std::to_string(high));
  }
  return static_cast<int64_t>(v);
}

// The same for counts kept in an int.
int IntAtLeast(const ConfigSection& s, const std::string& key, int fallback, int low,
               int high = std::numeric_limits<int>::max()) {
  return static_cast<int>(AtLeast(s, key, fallback, low, high));
}

}  // namespace

TrainerConfig ReadTrainerConfig(const ConfigSection& s) {
  TrainerConfig c;
  ConfigSection h = s.Section("hyperparameters");
  c.batch_size = AtLeast(h, "batch_size", c.batch_size, 1);
  c.buffer_size = AtLeast(h, "buffer_size", c.buffer_size, 1);
  if (c.buffer_size < c.batch_size) {
    h.Fail("buffer_size", "must be at least batch_size (" + std::to_string(c.batch_size) + ")");
  }
  c.learning_rate = PositiveNumber(h, "learning_rate", c.learning_rate);
  std::string schedule = h.Get<std::string>("learning_rate_schedule", "linear");
  if (schedule == "linear") {
    c.schedule = TrainerConfig::Schedule::kLinear;
  } else if (schedule == "constant") {
    c.schedule = TrainerConfig::Schedule::kConstant;
  } else if (schedule == "adaptive") {
    c.schedule = TrainerConfig::Schedule::kAdaptive;
  } else {
    h.Fail("learning_rate_schedule",
           "expected 'linear', 'constant' or 'adaptive', got '" + schedule + "'");
  }
  c.target_kl = PositiveNumber(h, "target_kl", c.target_kl);
  c.beta = h.Get<double>("beta", c.beta);
  if (!(c.beta >= 0)) h.Fail("beta", "must be zero or more");
  c.epsilon = PositiveNumber(h, "epsilon", c.epsilon);
  c.lambd = Fraction(h, "lambd", c.lambd);
  c.num_epoch = IntAtLeast(h, "num_epoch", c.num_epoch, 1);
  c.max_grad_norm = PositiveNumber(h, "max_grad_norm", c.max_grad_norm);
  c.value_coef = PositiveNumber(h, "value_coef", c.value_coef);
  c.clip_value_loss = h.Get<bool>("clip_value_loss", c.clip_value_loss);
  h.Finish();

  ConfigSection n = s.Section("network_settings");
  c.normalize = n.Get<bool>("normalize", c.normalize);
  // Far above any network this task trains (ML-Agents' defaults are 128 x 2), low enough that a
  // typo cannot ask for gigabytes: fuzz_config spent most of its time building 1e8-layer lists.
  int units = IntAtLeast(n, "hidden_units", 512, 1, 8192);
  int layers = IntAtLeast(n, "num_layers", 2, 1, 64);
  c.network.hidden_units.assign(layers, units);
  c.network.activation = n.Get<std::string>("activation", c.network.activation);
  if (c.network.activation != "tanh" && c.network.activation != "relu" &&
      c.network.activation != "elu") {
    n.Fail("activation", "expected tanh, relu or elu");
  }
  c.network.init_log_std = n.Get<double>("init_log_std", c.network.init_log_std);
  c.learn_log_std = n.Get<bool>("learn_log_std", c.learn_log_std);
  c.normalize_value = n.Get<bool>("normalize_value", c.normalize_value);
  n.Finish();

  ConfigSection rewards = s.Section("reward_signals");
  ConfigSection extrinsic = rewards.Section("extrinsic");
  c.gamma = Fraction(extrinsic, "gamma", c.gamma);
  extrinsic.Get<double>("strength", 1.0);  // ML-Agents' key; only one signal here, weight 1
  extrinsic.Finish();
  rewards.Finish();

  c.max_steps = AtLeast(s, "max_steps", c.max_steps, 1);
  c.time_horizon = IntAtLeast(s, "time_horizon", c.time_horizon, 1);
  c.checkpoint_interval = AtLeast(s, "checkpoint_interval", c.checkpoint_interval, 1);
  c.keep_checkpoints = IntAtLeast(s, "keep_checkpoints", c.keep_checkpoints, 1);
  c.max_policy_lag = IntAtLeast(s, "max_policy_lag", c.max_policy_lag, 0);
  c.threads = IntAtLeast(s, "threads", c.threads, 1);
  c.seed = static_cast<uint64_t>(AtLeast(s, "seed", static_cast<int64_t>(c.seed), 0));
  s.Finish();
  return c;
}

}  // namespace ragdoll::learner
