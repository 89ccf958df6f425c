#include "learner/raw_training.h"

#include <algorithm>
#include <chrono>
#include <vector>

namespace ragdoll::learner {
namespace {

std::vector<torch::Tensor> Parameters(GaussianPolicy& policy, ValueNetwork& critic) {
  std::vector<torch::Tensor> params = policy->parameters();
  for (const auto& p : critic->parameters()) params.push_back(p);
  return params;
}

}  // namespace

RawTraining::RawTraining(const TrainerConfig& config, int observation_size, int action_size,
                         int64_t minibatch)
    : policy_(observation_size, action_size, config.network),
      critic_(observation_size, config.network),
      adam_(Parameters(policy_, critic_), torch::optim::AdamOptions(config.learning_rate)),
      observations_(torch::randn({minibatch, observation_size})),
      actions_(torch::randn({minibatch, action_size})),
      values_(torch::randn({minibatch})) {}

double RawTraining::Rate(int64_t steps) {
  const auto start = std::chrono::steady_clock::now();
  for (int64_t s = 0; s < steps; ++s) {
    adam_.zero_grad();
    torch::Tensor loss = (policy_->forward(observations_) - actions_).pow(2).mean() +
                         (critic_->forward(observations_) - values_).pow(2).mean();
    loss.backward();
    adam_.step();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return static_cast<double>(steps * observations_.size(0)) / std::max(seconds, 1e-9);
}

double RawTraining::BestRate(int repeats, double seconds) {
  Rate(1);
  const auto start = std::chrono::steady_clock::now();
  double best = 0;
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  for (int r = 0; r < std::max(repeats, 1) && (r == 0 || elapsed() < seconds); ++r) {
    best = std::max(best, Rate(1));
  }
  return best;
}

int64_t RawTraining::parameters() const {
  int64_t n = 0;
  for (const auto& p : adam_.param_groups()[0].params()) n += p.numel();
  return n;
}

}  // namespace ragdoll::learner
