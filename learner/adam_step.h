// Adam's step in one pass over each parameter: torch::optim::Adam's arithmetic and its own state
// (the checkpoints keep saving and loading the optimiser as before), where libtorch's step makes
// about six passes (docs/benchmarks.md, "Learner replicas").
#pragma once

#include <torch/torch.h>

namespace ragdoll::learner {

// Steps `adam` as adam.step() would. Falls back to adam.step() when an option the pass does not
// do is set (weight decay, AMSGrad) or a parameter, its gradient or its state is not contiguous
// float32.
void AdamStep(torch::optim::Adam& adam);

}  // namespace ragdoll::learner
