#include "learner/adam_step.h"

#include <gtest/gtest.h>

#include <vector>

namespace ragdoll::learner {
namespace {

// Two copies of the same parameters (a matrix, a vector, one with no gradient this step).
std::vector<torch::Tensor> Parameters() {
  torch::manual_seed(7);
  return {torch::randn({67, 33}).requires_grad_(), torch::randn({33}).requires_grad_(),
          torch::randn({5}).requires_grad_()};
}

std::vector<torch::Tensor> Clone(const std::vector<torch::Tensor>& params) {
  std::vector<torch::Tensor> out;
  for (const auto& p : params) out.push_back(p.detach().clone().requires_grad_());
  return out;
}

void SetGradients(std::vector<torch::Tensor>& params, int step) {
  torch::manual_seed(100 + step);
  for (size_t i = 0; i + 1 < params.size(); ++i) {
    // Gradients of very different sizes, as a policy's layers have.
    params[i].mutable_grad() = torch::randn_like(params[i]) * (i == 0 ? 1e-3 : 10.0);
  }
}

// `steps` steps with the same gradients to both, ours by AdamStep, theirs by libtorch's step.
void StepBoth(std::vector<torch::Tensor>& ours, torch::optim::Adam& our_adam,
              std::vector<torch::Tensor>& theirs, torch::optim::Adam& their_adam, int steps) {
  for (int step = 0; step < steps; ++step) {
    SetGradients(ours, step);
    SetGradients(theirs, step);
    AdamStep(our_adam);
    their_adam.step();
  }
}

TEST(AdamStepTest, StepsAsLibtorchsAdamAndKeepsItsState) {
  std::vector<torch::Tensor> ours = Parameters(), theirs = Clone(ours);
  const auto options = torch::optim::AdamOptions(3e-3).eps(1e-8);
  torch::optim::Adam our_adam(ours, options), their_adam(theirs, options);
  StepBoth(ours, our_adam, theirs, their_adam, 25);
  for (size_t i = 0; i < ours.size(); ++i) {
    // The same arithmetic in another order: float rounding apart, over 25 steps.
    EXPECT_TRUE(torch::allclose(ours[i], theirs[i], 1e-5, 1e-6)) << "parameter " << i;
  }
  EXPECT_TRUE(ours[2].equal(theirs[2]));  // no gradient, no step
  // The state is libtorch's own: its step counts and moments, under the same keys.
  for (size_t i = 0; i + 1 < ours.size(); ++i) {
    const auto& mine = static_cast<torch::optim::AdamParamState&>(
        *our_adam.state().at(c10::guts::to_string(ours[i].unsafeGetTensorImpl())));
    const auto& reference = static_cast<torch::optim::AdamParamState&>(
        *their_adam.state().at(c10::guts::to_string(theirs[i].unsafeGetTensorImpl())));
    EXPECT_EQ(mine.step(), 25);
    EXPECT_EQ(mine.step(), reference.step());
    EXPECT_TRUE(torch::allclose(mine.exp_avg(), reference.exp_avg(), 1e-5, 1e-9));
    EXPECT_TRUE(torch::allclose(mine.exp_avg_sq(), reference.exp_avg_sq(), 1e-5, 1e-12));
  }
}

// A state written by one optimiser carries on in the other: a checkpoint's Adam resumes either way.
TEST(AdamStepTest, ContinuesFromLibtorchsStateAndBack) {
  std::vector<torch::Tensor> ours = Parameters(), theirs = Clone(ours);
  const auto options = torch::optim::AdamOptions(1e-3);
  torch::optim::Adam our_adam(ours, options), their_adam(theirs, options);
  for (int step = 0; step < 12; ++step) {
    SetGradients(ours, step);
    SetGradients(theirs, step);
    if (step < 4 || step >= 8) {
      our_adam.step();  // libtorch's steps first and last, ours between
    } else {
      AdamStep(our_adam);
    }
    their_adam.step();
  }
  for (size_t i = 0; i < ours.size(); ++i) {
    EXPECT_TRUE(torch::allclose(ours[i], theirs[i], 1e-5, 1e-6)) << "parameter " << i;
  }
}

// Options the one pass does not do are left to libtorch: the same bits as its own step.
TEST(AdamStepTest, LeavesWeightDecayAndAmsgradToLibtorch) {
  for (const auto& options : {torch::optim::AdamOptions(1e-3).weight_decay(0.01),
                              torch::optim::AdamOptions(1e-3).amsgrad(true)}) {
    std::vector<torch::Tensor> ours = Parameters(), theirs = Clone(ours);
    torch::optim::Adam our_adam(ours, options), their_adam(theirs, options);
    StepBoth(ours, our_adam, theirs, their_adam, 3);
    for (size_t i = 0; i < ours.size(); ++i) EXPECT_TRUE(ours[i].equal(theirs[i]));
  }
}

}  // namespace
}  // namespace ragdoll::learner
