// PPO update throughput against raw libtorch on the same networks in the same run: the raw loop
// is forward + backward + Adam on minibatches of the same size for the same number of gradient
// steps, with a plain squared-error loss; the ratio is what GAE, the PPO loss, minibatch
// gathering and bookkeeping cost on top.
//   ragdoll-bench-learner CONFIG [--repeats R]
#include <torch/torch.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "actor/rollout.h"
#include "cli/experiment.h"
#include "common/median.h"
#include "learner/learner.h"

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

int main(int argc, char** argv) {
  using namespace ragdoll;
  CLI::App app("PPO update samples/s vs raw libtorch forward+backward+Adam.");
  std::string config;
  int repeats = 5, threads = 1;
  app.add_option("config", config, "experiment YAML")->required();
  app.add_option("--repeats", repeats)->capture_default_str();
  app.add_option("--threads", threads, "libtorch intra-op threads")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    cli::Experiment e = cli::ReadExperiment(config);
    at::set_num_threads(threads);
    const learner::TrainerConfig& c = e.trainer;
    actor::RolloutWorker probe(e.environment, 1, 1, 0, "probe");
    const int O = probe.spec().observation_size, A = probe.spec().action_size;
    const int T = c.time_horizon;
    learner::Learner l(c, O, A);

    // Synthetic segments of the right sizes (the update's cost does not depend on the values).
    std::mt19937 rng(1);
    std::normal_distribution<float> g(0, 1);
    std::vector<float> obs((T + 1) * O), act(T * A), logp(T, -30.0f), rew(T);
    std::vector<uint8_t> flags(T, 0);
    auto fill = [&]() {
      while (!l.Ready()) {
        for (float& x : obs) x = g(rng);
        for (float& x : act) x = 0.3f * g(rng);
        for (float& x : rew) x = 0.5f + 0.1f * g(rng);
        v1::TrajectorySegment s;
        s.set_policy_version(l.version());
        *s.mutable_observations() = wire::FloatTensor(obs.data(), {T + 1, O});
        *s.mutable_actions() = wire::FloatTensor(act.data(), {T, A});
        *s.mutable_log_probs() = wire::FloatTensor(logp.data(), {T});
        *s.mutable_rewards() = wire::FloatTensor(rew.data(), {T});
        *s.mutable_terminated() = wire::ByteTensor(flags.data(), {T});
        *s.mutable_truncated() = wire::ByteTensor(flags.data(), {T});
        *s.mutable_final_observations() = wire::FloatTensor(obs.data(), {0, O});
        l.Add(s);
      }
    };

    // Raw libtorch on networks of the same shapes.
    GaussianPolicy policy(O, A, c.network);
    ValueNetwork critic(O, c.network);
    std::vector<torch::Tensor> params = policy->parameters();
    for (const auto& p : critic->parameters()) params.push_back(p);
    torch::optim::Adam adam(params, torch::optim::AdamOptions(c.learning_rate));
    const int64_t B = (c.buffer_size + T - 1) / T * T;
    const int64_t mb = std::min(c.batch_size, B);
    const int64_t steps = c.num_epoch * (B / mb);
    torch::Tensor x = torch::randn({mb, O}), ya = torch::randn({mb, A}), yv = torch::randn({mb});

    std::vector<double> ppo, raw, ratio;
    for (int r = 0; r < repeats; ++r) {
      fill();
      learner::UpdateStats u = l.Update();
      double ppo_rate = static_cast<double>(u.samples) * c.num_epoch / u.seconds;
      auto t0 = Clock::now();
      for (int64_t s = 0; s < steps; ++s) {
        adam.zero_grad();
        torch::Tensor loss =
            (policy->forward(x) - ya).pow(2).mean() + (critic->forward(x) - yv).pow(2).mean();
        loss.backward();
        adam.step();
      }
      double raw_rate = static_cast<double>(steps * mb) /
                        std::chrono::duration<double>(Clock::now() - t0).count();
      ppo.push_back(ppo_rate);
      raw.push_back(raw_rate);
      ratio.push_back(ppo_rate / raw_rate);
    }
    std::printf(
        "learner (%s, buffer %lld, minibatch %lld, %d epochs, network %d x %zu, %d "
        "thread%s, median of %d):\n",
        config.c_str(), static_cast<long long>(B), static_cast<long long>(mb), c.num_epoch,
        c.network.hidden_units.front(), c.network.hidden_units.size(), threads,
        threads == 1 ? "" : "s", repeats);
    std::printf("  raw libtorch fwd+bwd+Adam  %8.0f samples/s\n", Median(raw));
    std::printf("  PPO update (per epoch)     %8.0f samples/s  ratio %.3f\n", Median(ppo),
                Median(ratio));
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "ragdoll-bench-learner: %s\n", ex.what());
    return 1;
  }
  return 0;
}
