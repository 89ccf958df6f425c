#include "learner/adam_step.h"

#include <cmath>
#include <memory>
#include <string>

namespace ragdoll::learner {
namespace {

struct Coefficients {
  float beta1, beta2, keep1, keep2;  // keep = 1 - beta, taken in double as libtorch takes it
  float step_size, bias_correction2_sqrt, eps;
};

// Built with -O3 -fno-math-errno (learner/CMakeLists.txt) so that the loop vectorises; the AVX2
// clone is chosen at load time on CPUs that have it.
__attribute__((target_clones("avx2", "default"))) void Pass(float* param, const float* grad,
                                                            float* exp_avg, float* exp_avg_sq,
                                                            int64_t n, Coefficients c) {
  for (int64_t i = 0; i < n; ++i) {
    const float g = grad[i];
    const float m = exp_avg[i] * c.beta1 + c.keep1 * g;
    const float v = exp_avg_sq[i] * c.beta2 + c.keep2 * g * g;
    exp_avg[i] = m;
    exp_avg_sq[i] = v;
    param[i] -= c.step_size * m / (std::sqrt(v) / c.bias_correction2_sqrt + c.eps);
  }
}

bool Plain(const torch::Tensor& t) {
  return t.defined() && t.scalar_type() == torch::kFloat32 && t.is_contiguous();
}

}  // namespace

void AdamStep(torch::optim::Adam& adam) {
  for (auto& group : adam.param_groups()) {
    const auto& o = static_cast<const torch::optim::AdamOptions&>(group.options());
    bool plain = o.weight_decay() == 0 && !o.amsgrad();
    for (const auto& p : group.params()) {
      plain = plain && Plain(p) && (!p.grad().defined() || Plain(p.grad()));
      const auto found = adam.state().find(c10::guts::to_string(p.unsafeGetTensorImpl()));
      if (plain && found != adam.state().end()) {
        const auto& state = static_cast<const torch::optim::AdamParamState&>(*found->second);
        plain = Plain(state.exp_avg()) && Plain(state.exp_avg_sq());
      }
    }
    if (!plain) {
      adam.step();
      return;
    }
  }
  torch::NoGradGuard no_grad;
  auto& states = adam.state();
  for (auto& group : adam.param_groups()) {
    const auto& o = static_cast<const torch::optim::AdamOptions&>(group.options());
    const double beta1 = std::get<0>(o.betas()), beta2 = std::get<1>(o.betas());
    for (auto& p : group.params()) {
      if (!p.grad().defined()) continue;
      const std::string key = c10::guts::to_string(p.unsafeGetTensorImpl());
      auto found = states.find(key);
      if (found == states.end()) {
        auto state = std::make_unique<torch::optim::AdamParamState>();
        state->step(0);
        state->exp_avg(torch::zeros_like(p, torch::MemoryFormat::Contiguous));
        state->exp_avg_sq(torch::zeros_like(p, torch::MemoryFormat::Contiguous));
        found = states.emplace(key, std::move(state)).first;
      }
      auto& state = static_cast<torch::optim::AdamParamState&>(*found->second);
      state.step(state.step() + 1);
      const double bias_correction1 = 1 - std::pow(beta1, static_cast<double>(state.step()));
      const double bias_correction2 = 1 - std::pow(beta2, static_cast<double>(state.step()));
      const Coefficients c{static_cast<float>(beta1),
                           static_cast<float>(beta2),
                           static_cast<float>(1 - beta1),
                           static_cast<float>(1 - beta2),
                           static_cast<float>(o.lr() / bias_correction1),
                           static_cast<float>(std::sqrt(bias_correction2)),
                           static_cast<float>(o.eps())};
      Pass(p.data_ptr<float>(), p.grad().data_ptr<float>(), state.exp_avg().data_ptr<float>(),
           state.exp_avg_sq().data_ptr<float>(), p.numel(), c);
    }
  }
}

}  // namespace ragdoll::learner
