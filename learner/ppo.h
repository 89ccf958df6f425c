// Proximal Policy Optimisation, the math only: generalised advantage estimation and the clipped
// surrogate loss, written in the order and with the names of CleanRL's ppo_continuous_action.
// Pure functions of tensors, so tests can call them with hand-computed inputs.
#pragma once

#include <torch/torch.h>

namespace ragdoll::learner {

// Generalised advantage estimation over segments of T steps (Schulman et al. 2016), with
// terminated and truncated steps handled apart:
//   terminated[t] = 1: the episode failed; nothing follows (the next value is 0).
//   truncated[t] = 1:  the episode was cut short; bootstrap from next_values[t], the critic's
//                      value of that episode's final observation.
// Either way no advantage flows back across step t.
//
// All tensors are [N, T] float32 (N segments): rewards, values (V of each step's observation),
// next_values (V of the observation after each step: the next step's, or for a truncated step
// its episode's final observation, or for the last step the bootstrap observation), terminated
// and truncated (0/1).
// clang-format off
//   delta_t     = r_t + gamma * next_values_t * (1 - terminated_t) - values_t
//   advantage_t = delta_t + gamma * lambda * (1 - terminated_t) * (1 - truncated_t) * advantage_{t+1}
//   returns_t   = advantage_t + values_t
// clang-format on
struct GaeResult {
  torch::Tensor advantages;
  torch::Tensor returns;
};
GaeResult ComputeGae(const torch::Tensor& rewards, const torch::Tensor& values,
                     const torch::Tensor& next_values, const torch::Tensor& terminated,
                     const torch::Tensor& truncated, double gamma, double lambda);

struct PpoLossConfig {
  double clip_coef = 0.2;  // epsilon: the surrogate's clip range
  bool clip_vloss = true;  // clip the value update to the same range around old values
  double vf_coef = 0.5;    // weight of the value loss
  double ent_coef = 5e-4;  // beta: weight of the entropy bonus
  bool norm_adv = true;    // normalise advantages per minibatch
};

struct PpoLoss {
  torch::Tensor loss;  // pg_loss - ent_coef * entropy + vf_coef * v_loss (differentiable)
  // Detached scalars for reporting.
  double pg_loss = 0;
  double v_loss = 0;
  double entropy = 0;
  double approx_kl = 0;  // mean((ratio - 1) - log ratio), the unbiased estimator
  double clipfrac = 0;   // fraction of samples whose ratio left [1 - eps, 1 + eps]
};

// A minibatch's advantages less their mean, over their unbiased standard deviation (CleanRL's
// norm_adv). A minibatch of one keeps its raw advantage: its standard deviation is undefined.
torch::Tensor NormalizeAdvantages(const torch::Tensor& advantages);

// One minibatch's loss. newlogprob, entropy, newvalue: [B] from the current networks (with
// gradients); b_logprobs, b_advantages, b_returns, b_values: [B] from the rollout, where
// b_logprobs are the behaviour policy's log-probabilities (the actors' snapshot), so a version
// or two of policy lag is corrected by the importance ratio.
PpoLoss ComputePpoLoss(const PpoLossConfig& config, const torch::Tensor& newlogprob,
                       const torch::Tensor& entropy, const torch::Tensor& newvalue,
                       const torch::Tensor& b_logprobs, torch::Tensor b_advantages,
                       const torch::Tensor& b_returns, const torch::Tensor& b_values);

// KL(old || new) of diagonal Gaussian policies, summed over action dimensions and averaged over
// the batch: means [B, act], log standard deviations [act]. The update's own step (from the
// policy it started from), which unlike approx_kl does not include the actors' policy lag.
//   sum_a  log s_new - log s_old + (s_old^2 + (m_old - m_new)^2) / (2 s_new^2) - 1/2
double GaussianKl(const torch::Tensor& old_mean, const torch::Tensor& old_log_std,
                  const torch::Tensor& mean, const torch::Tensor& log_std);

// 1 - Var(returns - values) / Var(returns): how much of the return the critic explains.
double ExplainedVariance(const torch::Tensor& values, const torch::Tensor& returns);

// Linear decay to zero at max_steps (ML-Agents' "linear" schedule).
double LinearSchedule(double initial, int64_t samples, int64_t max_steps);

// The "adaptive" schedule (rl_games, as used for DeepMimic-style imitation in Isaac Gym): after
// a minibatch whose KL from the policy the update started from (GaussianKl) exceeded twice
// `target_kl`, the
// rate falls by 1.5x; below half of it, it rises by 1.5x; always within [1e-6, 1e-2]. Adam's step
// does not shrink with the action noise, so a fixed rate that suits a wide policy moves a narrow
// one many standard deviations per update; tying the rate to the KL keeps each update a
// trust-region step whatever the noise.
double AdaptiveLearningRate(double learning_rate, double approx_kl, double target_kl);

}  // namespace ragdoll::learner
