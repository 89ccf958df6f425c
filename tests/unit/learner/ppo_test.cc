#include "learner/ppo.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace ragdoll::learner {
namespace {

torch::Tensor Row(const std::vector<double>& v) {
  return torch::tensor(v, torch::dtype(torch::kFloat64));
}

torch::Tensor Grid(const std::vector<std::vector<float>>& rows) {
  const int64_t n = static_cast<int64_t>(rows.size());
  const int64_t t = static_cast<int64_t>(rows[0].size());
  torch::Tensor out = torch::empty({n, t}, torch::kFloat32);
  for (int64_t i = 0; i < n; ++i) {
    for (int64_t j = 0; j < t; ++j) out[i][j] = rows[i][j];
  }
  return out;
}

double At(const torch::Tensor& t, int64_t i, int64_t j) { return t[i][j].item<double>(); }

// ---------------------------------------------------------------------------------------------
// GAE

// gamma = 0.9, lambda = 0.8 (gamma * lambda = 0.72), rewards [1, 2, 3], values [0.5, 1, 1.5].
// Row 0: step 1 truncated (its episode's final observation is worth 2.0, not the next step's
// 1.5), step 2 terminated (the bootstrap value 4.0 must be ignored).
//   t=2: delta = 3 + 0            - 1.5 = 1.5;  A = 1.5                   ; R = 3.0
//   t=1: delta = 2 + 0.9 * 2.0    - 1.0 = 2.8;  A = 2.8 (nothing flows back); R = 3.8
//   t=0: delta = 1 + 0.9 * 1.0    - 0.5 = 1.4;  A = 1.4 + 0.72 * 2.8 = 3.416; R = 3.916
// Row 1: the same steps with no episode end (next values [1.0, 1.5, 4.0]).
//   t=2: delta = 3 + 0.9 * 4.0 - 1.5 = 5.1;   A = 5.1                       ; R = 6.6
//   t=1: delta = 2 + 0.9 * 1.5 - 1.0 = 2.35;  A = 2.35 + 0.72 * 5.1 = 6.022  ; R = 7.022
//   t=0: delta = 1 + 0.9 * 1.0 - 0.5 = 1.4;   A = 1.4 + 0.72 * 6.022 = 5.73584; R = 6.23584
TEST(Gae, HandComputedTerminatedAndTruncated) {
  const torch::Tensor rewards = Grid({{1, 2, 3}, {1, 2, 3}});
  const torch::Tensor values = Grid({{0.5, 1, 1.5}, {0.5, 1, 1.5}});
  const torch::Tensor next_values = Grid({{1, 2, 4}, {1, 1.5, 4}});
  const torch::Tensor terminated = Grid({{0, 0, 1}, {0, 0, 0}});
  const torch::Tensor truncated = Grid({{0, 1, 0}, {0, 0, 0}});
  GaeResult g = ComputeGae(rewards, values, next_values, terminated, truncated, 0.9, 0.8);
  ASSERT_EQ(g.advantages.sizes(), torch::IntArrayRef({2, 3}));
  ASSERT_EQ(g.returns.sizes(), torch::IntArrayRef({2, 3}));
  const double kTol = 1e-5;  // float32 results
  EXPECT_NEAR(At(g.advantages, 0, 2), 1.5, kTol);
  EXPECT_NEAR(At(g.advantages, 0, 1), 2.8, kTol);
  EXPECT_NEAR(At(g.advantages, 0, 0), 3.416, kTol);
  EXPECT_NEAR(At(g.returns, 0, 2), 3.0, kTol);
  EXPECT_NEAR(At(g.returns, 0, 1), 3.8, kTol);
  EXPECT_NEAR(At(g.returns, 0, 0), 3.916, kTol);
  EXPECT_NEAR(At(g.advantages, 1, 2), 5.1, kTol);
  EXPECT_NEAR(At(g.advantages, 1, 1), 6.022, kTol);
  EXPECT_NEAR(At(g.advantages, 1, 0), 5.73584, kTol);
  EXPECT_NEAR(At(g.returns, 1, 2), 6.6, kTol);
  EXPECT_NEAR(At(g.returns, 1, 1), 7.022, kTol);
  EXPECT_NEAR(At(g.returns, 1, 0), 6.23584, kTol);
}

// The advantage written as the explicit sum A_t = sum_{k >= t} (gamma lambda)^(k - t) delta_k,
// stopping after the first step that ends an episode (or at the segment's end).
std::vector<std::vector<double>> ReferenceAdvantages(const std::vector<std::vector<float>>& r,
                                                     const std::vector<std::vector<float>>& v,
                                                     const std::vector<std::vector<float>>& nv,
                                                     const std::vector<std::vector<float>>& term,
                                                     const std::vector<std::vector<float>>& trunc,
                                                     double gamma, double lambda) {
  std::vector<std::vector<double>> out(r.size());
  for (size_t n = 0; n < r.size(); ++n) {
    const size_t steps = r[n].size();
    for (size_t t = 0; t < steps; ++t) {
      double sum = 0, weight = 1;
      for (size_t k = t; k < steps; ++k) {
        const double bootstrap = term[n][k] != 0 ? 0.0 : static_cast<double>(nv[n][k]);
        const double delta = r[n][k] + gamma * bootstrap - v[n][k];
        sum += weight * delta;
        if (term[n][k] != 0 || trunc[n][k] != 0) break;
        weight *= gamma * lambda;
      }
      out[n].push_back(sum);
    }
  }
  return out;
}

TEST(Gae, MatchesScalarReferenceOnRandomSegments) {
  const int kN = 5, kT = 17;
  const double gamma = 0.97, lambda = 0.93;
  std::mt19937 rng(1234);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  std::vector<std::vector<float>> r(kN), v(kN), nv(kN), term(kN), trunc(kN);
  for (int n = 0; n < kN; ++n) {
    for (int t = 0; t < kT; ++t) {
      r[n].push_back(normal(rng));
      v[n].push_back(3.0f * normal(rng));
      nv[n].push_back(3.0f * normal(rng));
      const float u = uniform(rng);
      term[n].push_back(u < 0.15f ? 1.0f : 0.0f);
      trunc[n].push_back(u > 0.85f ? 1.0f : 0.0f);
    }
  }
  // Force each kind of episode end at the last step and in the middle, and leave one row with
  // no episode end at all.
  term[0][kT - 1] = 1, trunc[0][kT - 1] = 0;
  term[1][kT - 1] = 0, trunc[1][kT - 1] = 1;
  term[2][kT - 1] = 0, trunc[2][kT - 1] = 0;
  term[3][5] = 1, trunc[3][5] = 0;
  term[3][11] = 0, trunc[3][11] = 1;
  std::fill(term[4].begin(), term[4].end(), 0.0f);
  std::fill(trunc[4].begin(), trunc[4].end(), 0.0f);
  int ends = 0;
  for (int n = 0; n < kN; ++n) {
    for (int t = 0; t < kT - 1; ++t) ends += term[n][t] != 0 || trunc[n][t] != 0;
  }
  ASSERT_GE(ends, 4) << "the random data should end episodes in the middle of segments";

  GaeResult g = ComputeGae(Grid(r), Grid(v), Grid(nv), Grid(term), Grid(trunc), gamma, lambda);
  const auto expected = ReferenceAdvantages(r, v, nv, term, trunc, gamma, lambda);
  for (int n = 0; n < kN; ++n) {
    for (int t = 0; t < kT; ++t) {
      const double tol = 1e-5 * (1.0 + std::abs(expected[n][t]));
      EXPECT_NEAR(At(g.advantages, n, t), expected[n][t], tol) << "n=" << n << " t=" << t;
      EXPECT_NEAR(At(g.returns, n, t), expected[n][t] + v[n][t], tol) << "n=" << n << " t=" << t;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// PPO loss on a hand-computed minibatch of four.
//
// ratio = [1.5, 0.7, 1.1, 1.4], clip_coef = 0.2, so clamp(ratio) = [1.2, 0.8, 1.1, 1.2] and
// three of four ratios leave [0.8, 1.2]: clipfrac = 0.75.
// advantages = [1, -2, 3, -0.5]:
//   max(-A r, -A clamp(r)) = [max(-1.5, -1.2), max(1.4, 1.6), -3.3, max(0.7, 0.6)]
//                          = [-1.2, 1.6, -3.3, 0.7]  -> pg_loss = -2.2 / 4 = -0.55
// Normalised: mean 0.375, unbiased std sqrt(13.6875 / 3) = sqrt(4.5625) = 2.13600094,
//   a = [0.625, -2.375, 2.625, -0.875] / (std + 1e-8): same signs, so the same terms win:
//   pg_loss = -(1.2 * 0.625 - 0.8 * 2.375 + 1.1 * 2.625 - 1.4 * 0.875) / (4 (std + 1e-8))
//           = -0.128125 / (std + 1e-8) = -0.0599835877
// newvalue = [1, 2, 0.5, 3], b_values = [0.5, 2.1, 1, 0], b_returns = [2, 1, 0, 1]:
//   unclipped (v - R)^2 = [1, 1, 0.25, 4]                 -> v_loss = 0.5 * 6.25 / 4 = 0.78125
//   v_clipped = [0.7, 2.0, 0.8, 0.2], (v_clipped - R)^2 = [1.69, 1, 0.64, 0.64]
//   max = [1.69, 1, 0.64, 4]                              -> v_loss = 0.5 * 7.33 / 4 = 0.91625
// entropy = [1, 1.2, 0.8, 1.4] -> 1.1; ent_coef = 0.01, vf_coef = 0.5.
struct Minibatch {
  torch::Tensor newlogprob, entropy, newvalue, b_logprobs, b_advantages, b_returns, b_values;
};

Minibatch HandMinibatch() {
  Minibatch m;
  m.b_logprobs = Row({-1, -1, -1, -1});
  m.newlogprob = (torch::log(Row({1.5, 0.7, 1.1, 1.4})) - 1.0).requires_grad_(true);
  m.entropy = Row({1, 1.2, 0.8, 1.4}).requires_grad_(true);
  m.newvalue = Row({1, 2, 0.5, 3}).requires_grad_(true);
  m.b_advantages = Row({1, -2, 3, -0.5});
  m.b_returns = Row({2, 1, 0, 1});
  m.b_values = Row({0.5, 2.1, 1, 0});
  return m;
}

PpoLossConfig HandConfig(bool norm_adv, bool clip_vloss) {
  PpoLossConfig c;
  c.clip_coef = 0.2;
  c.vf_coef = 0.5;
  c.ent_coef = 0.01;
  c.norm_adv = norm_adv;
  c.clip_vloss = clip_vloss;
  return c;
}

PpoLoss Loss(const PpoLossConfig& c, const Minibatch& m) {
  return ComputePpoLoss(c, m.newlogprob, m.entropy, m.newvalue, m.b_logprobs, m.b_advantages,
                        m.b_returns, m.b_values);
}

const double kApproxKl = ((0.5 - std::log(1.5)) + (-0.3 - std::log(0.7)) + (0.1 - std::log(1.1)) +
                          (0.4 - std::log(1.4))) /
                         4;  // 0.0548568549

TEST(PpoLoss, HandComputedRawAdvantagesClippedValue) {
  const Minibatch m = HandMinibatch();
  const PpoLoss l = Loss(HandConfig(/*norm_adv=*/false, /*clip_vloss=*/true), m);
  EXPECT_NEAR(l.pg_loss, -0.55, 1e-6);
  EXPECT_NEAR(l.v_loss, 0.91625, 1e-6);
  EXPECT_NEAR(l.entropy, 1.1, 1e-6);
  EXPECT_NEAR(l.approx_kl, kApproxKl, 1e-6);
  EXPECT_NEAR(l.approx_kl, 0.0548568549, 1e-6);
  EXPECT_NEAR(l.clipfrac, 0.75, 1e-6);
  // -0.55 - 0.01 * 1.1 + 0.5 * 0.91625
  EXPECT_NEAR(l.loss.item<double>(), -0.102875, 1e-6);
}

TEST(PpoLoss, HandComputedRawAdvantagesUnclippedValue) {
  const Minibatch m = HandMinibatch();
  const PpoLoss l = Loss(HandConfig(/*norm_adv=*/false, /*clip_vloss=*/false), m);
  EXPECT_NEAR(l.pg_loss, -0.55, 1e-6);
  EXPECT_NEAR(l.v_loss, 0.78125, 1e-6);
  EXPECT_NEAR(l.entropy, 1.1, 1e-6);
  EXPECT_NEAR(l.approx_kl, kApproxKl, 1e-6);
  EXPECT_NEAR(l.clipfrac, 0.75, 1e-6);
  // -0.55 - 0.011 + 0.5 * 0.78125
  EXPECT_NEAR(l.loss.item<double>(), -0.170375, 1e-6);
}

TEST(PpoLoss, HandComputedNormalisedAdvantages) {
  const Minibatch m = HandMinibatch();
  const double pg = -0.128125 / (std::sqrt(4.5625) + 1e-8);
  EXPECT_NEAR(pg, -0.0599835877, 1e-9);
  for (bool clip_vloss : {true, false}) {
    const PpoLoss l = Loss(HandConfig(/*norm_adv=*/true, clip_vloss), m);
    const double v_loss = clip_vloss ? 0.91625 : 0.78125;
    EXPECT_NEAR(l.pg_loss, pg, 1e-6);
    EXPECT_NEAR(l.v_loss, v_loss, 1e-6);
    EXPECT_NEAR(l.entropy, 1.1, 1e-6);
    EXPECT_NEAR(l.approx_kl, kApproxKl, 1e-6);
    EXPECT_NEAR(l.clipfrac, 0.75, 1e-6);
    EXPECT_NEAR(l.loss.item<double>(), pg - 0.011 + 0.5 * v_loss, 1e-6);
  }
  // The caller's advantages are not normalised in place.
  EXPECT_NEAR(m.b_advantages[0].item<double>(), 1.0, 0.0);
}

// The clip removes the gradient of samples whose ratio left the trust region in the direction
// the advantage favours; the others get d/dlogp (-A r) / B = -A r / 4.
TEST(PpoLoss, GradientsFollowTheClippedTerms) {
  const Minibatch m = HandMinibatch();
  const PpoLoss l = Loss(HandConfig(/*norm_adv=*/false, /*clip_vloss=*/true), m);
  l.loss.backward();
  const torch::Tensor g_logp = m.newlogprob.grad();
  EXPECT_NEAR(g_logp[0].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(g_logp[1].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(g_logp[2].item<double>(), -3 * 1.1 / 4, 1e-9);
  EXPECT_NEAR(g_logp[3].item<double>(), 0.5 * 1.4 / 4, 1e-9);
  // vf_coef * 0.5 / B * d(max)/dv: samples 0 and 2 are held by the clipped value (no gradient),
  // samples 1 and 3 give 2 (v - R) = 2 and 4.
  const torch::Tensor g_v = m.newvalue.grad();
  EXPECT_NEAR(g_v[0].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(g_v[1].item<double>(), 0.0625 * 2, 1e-9);
  EXPECT_NEAR(g_v[2].item<double>(), 0.0, 1e-12);
  EXPECT_NEAR(g_v[3].item<double>(), 0.0625 * 4, 1e-9);
  // -ent_coef / B for every sample.
  EXPECT_TRUE(torch::allclose(m.entropy.grad(), torch::full({4}, -0.0025, torch::kFloat64)));
}

// {1, -2, 3, -0.5}: mean 0.375, unbiased variance 18.25 / 4 = 4.5625.
TEST(PpoLoss, NormalizeAdvantagesByTheMinibatchMeanAndUnbiasedStd) {
  const torch::Tensor a = NormalizeAdvantages(Row({1, -2, 3, -0.5}));
  const double sd = std::sqrt(4.5625) + 1e-8;
  const double expected[] = {0.625 / sd, -2.375 / sd, 2.625 / sd, -0.875 / sd};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(a[i].item<double>(), expected[i], 1e-12);
  EXPECT_EQ(NormalizeAdvantages(Row({3.0})).item<double>(), 3.0);
}

TEST(PpoLoss, SingleSampleMinibatchKeepsRawAdvantage) {
  const PpoLoss l =
      ComputePpoLoss(HandConfig(/*norm_adv=*/true, /*clip_vloss=*/false), Row({-1 + std::log(1.1)}),
                     Row({1.0}), Row({2.0}), Row({-1}), Row({3.0}), Row({1.0}), Row({2.0}));
  EXPECT_NEAR(l.pg_loss, -3 * 1.1, 1e-9);
  EXPECT_NEAR(l.v_loss, 0.5, 1e-12);
  EXPECT_TRUE(std::isfinite(l.loss.item<double>()));
}

// ---------------------------------------------------------------------------------------------
// A tiny Gaussian policy: mean = W obs + b (Linear(3, 2)), state-independent log-std, and a
// Linear(3, 1) critic. The log-density is written out here, not taken from a distribution class.
TEST(PpoPolicyGradient, AdamStepOnTinyGaussianPolicyReducesTheLoss) {
  torch::nn::Linear actor(3, 2);
  torch::nn::Linear critic(3, 1);
  torch::Tensor log_std = torch::tensor({-0.5f, 0.2f}).requires_grad_(true);
  {
    torch::NoGradGuard no_grad;
    actor->weight.copy_(torch::tensor({{0.1f, -0.2f, 0.3f}, {0.4f, 0.0f, -0.1f}}));
    actor->bias.copy_(torch::tensor({0.05f, -0.05f}));
    critic->weight.copy_(torch::tensor({{0.2f, 0.1f, -0.3f}}));
    critic->bias.copy_(torch::tensor({0.1f}));
  }
  const torch::Tensor obs = torch::tensor(
      {{1.0f, 0.5f, -1.0f}, {0.0f, 1.0f, 2.0f}, {-1.0f, -0.5f, 0.5f}, {2.0f, 0.0f, 1.0f}});
  const torch::Tensor actions =
      torch::tensor({{0.3f, 0.1f}, {-0.4f, 0.2f}, {0.0f, -0.6f}, {0.5f, 0.9f}});

  constexpr double kLog2Pi = 1.8378770664093453;
  auto logprob_of = [&]() {
    const torch::Tensor mean = actor->forward(obs);
    const torch::Tensor var = torch::exp(2 * log_std);
    return (-(actions - mean).pow(2) / (2 * var) - log_std - 0.5 * kLog2Pi).sum(1);
  };
  auto entropy_of = [&]() { return (0.5 + 0.5 * kLog2Pi + log_std).sum().expand({4}); };

  // Sample 0 by hand: mean = [0.1 * 1 - 0.2 * 0.5 + 0.3 * -1 + 0.05, 0.4 * 1 - 0.1 * -1 - 0.05]
  // = [-0.25, 0.45]; sigma = [e^-0.5, e^0.2].
  {
    const double s0 = std::exp(-0.5), s1 = std::exp(0.2);
    const double expected = -std::pow(0.3 + 0.25, 2) / (2 * s0 * s0) - std::log(s0) -
                            std::pow(0.1 - 0.45, 2) / (2 * s1 * s1) - std::log(s1) - kLog2Pi;
    EXPECT_NEAR(logprob_of()[0].item<double>(), expected, 1e-5);
  }

  // The behaviour policy was a little different, so ratios sit inside the clip range and every
  // sample contributes gradient.
  const torch::Tensor b_logprobs =
      logprob_of().detach() + torch::tensor({0.05f, -0.05f, 0.1f, -0.1f});
  const torch::Tensor b_advantages = torch::tensor({1.0f, -0.5f, 0.8f, -1.2f});
  const torch::Tensor b_values = critic->forward(obs).squeeze(1).detach();
  const torch::Tensor b_returns = torch::tensor({1.0f, 0.5f, -0.5f, 2.0f});
  PpoLossConfig config;

  std::vector<torch::Tensor> params = {actor->weight, actor->bias, critic->weight, critic->bias,
                                       log_std};
  torch::optim::Adam adam(params, torch::optim::AdamOptions(1e-2));
  auto loss_now = [&]() {
    return ComputePpoLoss(config, logprob_of(), entropy_of(), critic->forward(obs).squeeze(1),
                          b_logprobs, b_advantages, b_returns, b_values);
  };
  const PpoLoss before = loss_now();
  EXPECT_EQ(before.clipfrac, 0.0);
  adam.zero_grad();
  before.loss.backward();
  for (size_t i = 0; i < params.size(); ++i) {
    const torch::Tensor g = params[i].grad();
    ASSERT_TRUE(g.defined()) << "parameter " << i;
    EXPECT_TRUE(torch::isfinite(g).all().item<bool>()) << "parameter " << i;
    EXPECT_GT(g.abs().sum().item<double>(), 1e-6) << "parameter " << i;
  }
  adam.step();
  const PpoLoss after = loss_now();
  EXPECT_LT(after.loss.item<double>(), before.loss.item<double>());
}

// ---------------------------------------------------------------------------------------------

TEST(PpoExplainedVariance, PerfectConstantAndPartialCritics) {
  const torch::Tensor returns = torch::tensor({1.0f, 2.0f, 3.0f, 4.0f});
  EXPECT_NEAR(ExplainedVariance(returns, returns), 1.0, 1e-12);
  EXPECT_NEAR(ExplainedVariance(torch::full({4}, 2.5f), returns), 0.0, 1e-12);
  EXPECT_NEAR(ExplainedVariance(torch::full({4}, -7.0f), returns), 0.0, 1e-12);
  // residual [0, 0, 0, -1]: population variance 0.1875; Var(returns) = 1.25; 1 - 0.15 = 0.85.
  EXPECT_NEAR(ExplainedVariance(torch::tensor({1.0f, 2.0f, 3.0f, 5.0f}), returns), 0.85, 1e-7);
  // A critic worse than a constant explains a negative fraction: residual [2, 2, -2, -2] has
  // variance 4, so 1 - 4 / 1.25 = -2.2.
  EXPECT_NEAR(ExplainedVariance(torch::tensor({-1.0f, 0.0f, 5.0f, 6.0f}), returns), -2.2, 1e-7);
}

TEST(PpoExplainedVariance, ConstantReturnsGiveZeroNotNaN) {
  EXPECT_EQ(ExplainedVariance(torch::tensor({0.5f, 1.0f, 2.0f}), torch::full({3}, 3.0f)), 0.0);
}

TEST(PpoSchedule, LinearDecayToZeroAtMaxSteps) {
  EXPECT_DOUBLE_EQ(LinearSchedule(3e-4, 0, 1000), 3e-4);
  EXPECT_DOUBLE_EQ(LinearSchedule(3e-4, 250, 1000), 2.25e-4);
  EXPECT_DOUBLE_EQ(LinearSchedule(3e-4, 500, 1000), 1.5e-4);
  EXPECT_DOUBLE_EQ(LinearSchedule(3e-4, 1000, 1000), 0.0);
  EXPECT_DOUBLE_EQ(LinearSchedule(3e-4, 5000, 1000), 0.0);
  EXPECT_THROW(LinearSchedule(3e-4, 10, 0), std::invalid_argument);
}

TEST(PpoGaussianKl, MatchesTheClosedFormByHand) {
  // Identical policies: 0.
  torch::Tensor mean = torch::tensor({{0.5f, -1.0f}, {0.0f, 2.0f}});
  torch::Tensor log_std = torch::tensor({-1.0f, 0.0f});
  EXPECT_NEAR(GaussianKl(mean, log_std, mean, log_std), 0.0, 1e-7);
  // One sample, one dimension: old N(0, 1), new N(0.5, e^-1):
  // -1 - 0 + (1 + 0.25) / (2 e^-2) - 0.5 = 0.625 e^2 - 1.5 = 3.11822...
  EXPECT_NEAR(GaussianKl(torch::tensor({{0.0f}}), torch::tensor({0.0f}), torch::tensor({{0.5f}}),
                         torch::tensor({-1.0f})),
              0.625 * std::exp(2.0) - 1.5, 1e-5);
  // Summed over dimensions, averaged over samples: means shifted by 0.1 and 0.3 at std 1 give
  // 0.005 and 0.045 per sample (d^2 / 2), so a mean of 0.025.
  EXPECT_NEAR(GaussianKl(torch::tensor({{0.0f, 0.0f}, {0.0f, 0.0f}}), torch::tensor({0.0f, 0.0f}),
                         torch::tensor({{0.1f, 0.0f}, {0.0f, 0.3f}}), torch::tensor({0.0f, 0.0f})),
              0.025, 1e-6);
}

TEST(PpoSchedule, AdaptiveFollowsTheKlWithinBounds) {
  // target 0.01: above 0.02 the rate falls by 1.5, below 0.005 it rises by 1.5, else stays.
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, 0.021, 0.01), 2e-4);
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, 0.004, 0.01), 4.5e-4);
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, 0.01, 0.01), 3e-4);
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, 0.02, 0.01), 3e-4);   // the bounds themselves
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, 0.005, 0.01), 3e-4);  // keep the rate
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(1.2e-6, 1.0, 0.01), 1e-6);  // floor
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(8e-3, 0.0, 0.01), 1e-2);    // ceiling
  EXPECT_DOUBLE_EQ(AdaptiveLearningRate(3e-4, NAN, 0.01), 2e-4);    // a NaN KL never raises it
}

}  // namespace
}  // namespace ragdoll::learner
