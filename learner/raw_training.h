// Plain libtorch forward+backward+Adam on networks of a trainer's shapes: the most a PPO update of
// that shape can run on this machine, the figure the learner's own rate is judged against (at
// start-up, and by the learner benchmark and `ragdoll doctor`).
#pragma once

#include <torch/torch.h>

#include <cstdint>

#include "common/policy.h"
#include "learner/trainer_config.h"

namespace ragdoll::learner {

class RawTraining {
 public:
  // The trainer's policy and critic on observations of `observation_size` and actions of
  // `action_size`, trained on random minibatches of `minibatch` samples.
  RawTraining(const TrainerConfig& config, int observation_size, int action_size,
              int64_t minibatch);
  // Samples per second over `steps` gradient steps, at the intra-op thread count already set.
  double Rate(int64_t steps);
  // The best of Rate(1) after one step's warm-up, over `repeats` steps or fewer once `seconds`
  // have passed (a start-up figure that stays short on large networks).
  double BestRate(int repeats, double seconds);
  int64_t parameters() const;

 private:
  GaussianPolicy policy_;
  ValueNetwork critic_;
  torch::optim::Adam adam_;
  torch::Tensor observations_, actions_, values_;
};

}  // namespace ragdoll::learner
