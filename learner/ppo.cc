#include "learner/ppo.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

namespace ragdoll::learner {

GaeResult ComputeGae(const torch::Tensor& rewards, const torch::Tensor& values,
                     const torch::Tensor& next_values, const torch::Tensor& terminated,
                     const torch::Tensor& truncated, double gamma, double lambda) {
  TORCH_CHECK(rewards.dim() == 2, "ComputeGae: rewards must be [N, T], got ", rewards.sizes());
  for (const torch::Tensor* t : {&values, &next_values, &terminated, &truncated}) {
    TORCH_CHECK(t->sizes() == rewards.sizes(), "ComputeGae: every input must be [N, T] like ",
                "rewards ", rewards.sizes(), ", got ", t->sizes());
  }
  // Advantages are targets, not part of the graph.
  torch::NoGradGuard no_grad;
  const auto options = rewards.options().dtype(torch::kFloat32);
  const torch::Tensor r = rewards.to(torch::kFloat32);
  const torch::Tensor v = values.to(torch::kFloat32);
  const torch::Tensor next_v = next_values.to(torch::kFloat32);
  const torch::Tensor not_terminated = 1.0f - terminated.to(torch::kFloat32);
  // Nothing flows back across the end of an episode, whether it failed or was cut short.
  const torch::Tensor continues = not_terminated * (1.0f - truncated.to(torch::kFloat32));

  const int64_t n = rewards.size(0);
  const int64_t steps = rewards.size(1);
  torch::Tensor advantages = torch::zeros({n, steps}, options);
  // advantage_{t+1}; zero beyond the segment's last step.
  torch::Tensor lastgaelam = torch::zeros({n}, options);
  for (int64_t t = steps - 1; t >= 0; --t) {
    const torch::Tensor delta =
        r.select(1, t) + gamma * next_v.select(1, t) * not_terminated.select(1, t) - v.select(1, t);
    lastgaelam = delta + gamma * lambda * continues.select(1, t) * lastgaelam;
    advantages.select(1, t).copy_(lastgaelam);
  }
  return {advantages, advantages + v};
}

torch::Tensor NormalizeAdvantages(const torch::Tensor& advantages) {
  // The unbiased std (as CleanRL) is undefined for a single sample, so a minibatch of one keeps
  // its raw advantage rather than turning the loss into NaN.
  if (advantages.numel() <= 1) return advantages;
  return (advantages - advantages.mean()) / (advantages.std() + 1e-8);
}

PpoLoss ComputePpoLoss(const PpoLossConfig& config, const torch::Tensor& newlogprob,
                       const torch::Tensor& entropy, const torch::Tensor& newvalue,
                       const torch::Tensor& b_logprobs, torch::Tensor b_advantages,
                       const torch::Tensor& b_returns, const torch::Tensor& b_values) {
  const auto batch = newlogprob.sizes();
  TORCH_CHECK(newlogprob.dim() == 1, "ComputePpoLoss: newlogprob must be [B], got ", batch);
  for (const torch::Tensor* t : std::initializer_list<const torch::Tensor*>{
           &entropy, &newvalue, &b_logprobs, &b_advantages, &b_returns, &b_values}) {
    TORCH_CHECK(t->sizes() == batch, "ComputePpoLoss: every input must be [B] like newlogprob ",
                batch, ", got ", t->sizes());
  }
  const torch::Tensor logratio = newlogprob - b_logprobs;
  const torch::Tensor ratio = logratio.exp();

  PpoLoss out;
  {
    torch::NoGradGuard no_grad;
    // Schulman's k3 estimator of KL(old || new): unbiased and always >= 0.
    out.approx_kl = ((ratio - 1) - logratio).mean().item<double>();
    out.clipfrac =
        ((ratio - 1.0).abs() > config.clip_coef).to(torch::kFloat64).mean().item<double>();
  }

  if (config.norm_adv) b_advantages = NormalizeAdvantages(b_advantages);

  // Clipped surrogate (Schulman et al. 2017, eq. 7), as a loss to minimise.
  const torch::Tensor pg_loss1 = -b_advantages * ratio;
  const torch::Tensor pg_loss2 =
      -b_advantages * torch::clamp(ratio, 1.0 - config.clip_coef, 1.0 + config.clip_coef);
  const torch::Tensor pg_loss = torch::max(pg_loss1, pg_loss2).mean();

  torch::Tensor v_loss;
  if (config.clip_vloss) {
    const torch::Tensor v_loss_unclipped = (newvalue - b_returns).pow(2);
    const torch::Tensor v_clipped =
        b_values + torch::clamp(newvalue - b_values, -config.clip_coef, config.clip_coef);
    const torch::Tensor v_loss_clipped = (v_clipped - b_returns).pow(2);
    v_loss = 0.5 * torch::max(v_loss_unclipped, v_loss_clipped).mean();
  } else {
    v_loss = 0.5 * (newvalue - b_returns).pow(2).mean();
  }

  const torch::Tensor entropy_loss = entropy.mean();
  out.loss = pg_loss - config.ent_coef * entropy_loss + config.vf_coef * v_loss;
  out.pg_loss = pg_loss.item<double>();
  out.v_loss = v_loss.item<double>();
  out.entropy = entropy_loss.item<double>();
  return out;
}

double ExplainedVariance(const torch::Tensor& values, const torch::Tensor& returns) {
  TORCH_CHECK(values.sizes() == returns.sizes(), "ExplainedVariance: values ", values.sizes(),
              " and returns ", returns.sizes(), " differ in shape");
  torch::NoGradGuard no_grad;
  const torch::Tensor y = returns.to(torch::kFloat64).flatten();
  const torch::Tensor y_pred = values.to(torch::kFloat64).flatten();
  if (y.numel() == 0) return 0.0;
  // Population variances, as numpy's np.var in CleanRL; the ratio does not depend on the choice.
  const double var_y = y.var(/*unbiased=*/false).item<double>();
  // Constant returns leave nothing to explain. CleanRL reports NaN here; 0 keeps the metric and
  // any average of it finite, and says the critic explains nothing.
  if (var_y == 0.0) return 0.0;
  return 1.0 - (y - y_pred).var(/*unbiased=*/false).item<double>() / var_y;
}

double GaussianKl(const torch::Tensor& old_mean, const torch::Tensor& old_log_std,
                  const torch::Tensor& mean, const torch::Tensor& log_std) {
  torch::NoGradGuard no_grad;
  const torch::Tensor old_var = torch::exp(2 * old_log_std);
  const torch::Tensor var = torch::exp(2 * log_std);
  const torch::Tensor d = old_mean - mean;
  const torch::Tensor kl = (log_std - old_log_std) + (old_var + d * d) / (2 * var) - 0.5;
  return kl.sum(-1).mean().item<double>();
}

double AdaptiveLearningRate(double learning_rate, double approx_kl, double target_kl) {
  constexpr double kFactor = 1.5, kMin = 1e-6, kMax = 1e-2;
  if (!std::isfinite(approx_kl)) return std::max(kMin, learning_rate / kFactor);
  if (approx_kl > 2 * target_kl) learning_rate /= kFactor;
  if (approx_kl < 0.5 * target_kl) learning_rate *= kFactor;
  return std::clamp(learning_rate, kMin, kMax);
}

double LinearSchedule(double initial, int64_t samples, int64_t max_steps) {
  if (max_steps <= 0) {
    throw std::invalid_argument("LinearSchedule: max_steps must be greater than 0, got " +
                                std::to_string(max_steps));
  }
  const double frac = 1.0 - static_cast<double>(samples) / static_cast<double>(max_steps);
  return initial * std::max(0.0, frac);
}

}  // namespace ragdoll::learner
