// PPO update throughput against raw libtorch on the same networks in the same run: the raw loop
// is forward + backward + Adam on minibatches of the same size for the same number of gradient
// steps, with a plain squared-error loss; the ratio is what GAE, the PPO loss, minibatch
// gathering and bookkeeping cost on top.
//   ragdoll-bench-learner CONFIG [--repeats R] [--threads T] [--replicas N]
// With --replicas N, the same update also runs on a group of N replica processes (c10d Gloo on
// loopback, replica i pinned to core i, each on its share of the buffer), each of its updates
// after one of a lone replica on core 0: the group's samples/s against one replica's, round by
// round, with nothing else running. That is the learner's own scaling; ragdoll-bench-cluster
// measures it with the broker and actors. The group also times its gradient all-reduce alone,
// against the share of a gradient step it would cost each replica.
#include <torch/torch.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <sched.h>
#include <unistd.h>

#include "bench/measure.h"
#include "common/allocator.h"
#include "common/blas.h"
#include "common/median.h"
#include "common/process.h"
#include "learner/learner.h"
#include "learner/replica_group.h"
#include "run/experiment.h"
#include "sim/imitation_env.h"

namespace {

using namespace ragdoll;
using Clock = std::chrono::steady_clock;

void PinToCore(int core) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(core % static_cast<int>(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN))), &set);
  sched_setaffinity(0, sizeof(set), &set);
}

// One replica of a group: `repeats` rounds after one to warm up. In each, rank 0 first runs the
// same update alone (a lone learner on the whole buffer, on the same core, the other replicas
// waiting), then the group runs its update: the two are timed seconds apart, so the machine's
// drift (on these shared machines, tens of per cent over minutes) cancels in each round's ratio.
// Rank 0 prints the medians on stdout.
int RunReplica(const run::Experiment& e, int rank, int replicas, int port, int repeats) {
  PinToCore(rank);
  at::set_num_threads(1);
  const learner::TrainerConfig& c = e.trainer;
  const sim::EnvSpec spec = sim::MakeEnvSpec(e.environment);
  const int O = spec.observation_size, A = spec.action_size;
  learner::ReplicaGroupConfig gc;
  gc.rank = rank;
  gc.size = replicas;
  gc.store_port = port;
  learner::ReplicaGroup group(gc);
  learner::Learner l(c, O, A, &group);
  l.SyncFromRankZero();
  std::unique_ptr<learner::Learner> alone;
  if (rank == 0) alone = std::make_unique<learner::Learner>(c, O, A);
  std::mt19937 rng(static_cast<unsigned>(1 + rank));
  const auto rate = [&](const learner::UpdateStats& u) {
    return static_cast<double>(u.samples) * c.num_epoch / u.seconds;
  };
  std::vector<double> rates, alone_rates, ratios;
  for (int r = 0; r <= repeats; ++r) {
    double alone_rate = 0;
    if (alone) {
      bench::FillWithSyntheticSegments(*alone, c.time_horizon, O, A, rng);
      alone_rate = rate(alone->Update());
    }
    torch::Tensor done = torch::zeros({1});
    group.Sum(done);  // the others wait here while rank 0 updates alone
    bench::FillWithSyntheticSegments(l, c.time_horizon, O, A, rng);
    l.AgreeToUpdate(false);
    const double group_rate = rate(l.Update());
    if (r == 0 || !alone) continue;  // rank 0 alone keeps the figures
    rates.push_back(group_rate);
    alone_rates.push_back(alone_rate);
    ratios.push_back(group_rate / alone_rate);
  }
  // The gradient all-reduce on its own, as each gradient step above makes it: every trained
  // parameter and the KL slot, in float32.
  const int64_t floats = l.trained_parameters() + 1;
  torch::Tensor gradients = torch::zeros({floats});
  std::vector<double> times;
  for (int i = 0; i < 60; ++i) {
    auto t0 = Clock::now();
    group.Sum(gradients);
    if (i >= 10) times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  if (rank == 0) {
    std::printf("%.1f %.1f %.4f %.4f %.4f %.6f %lld\n", Median(rates), Median(alone_rates),
                Median(ratios), *std::min_element(ratios.begin(), ratios.end()),
                *std::max_element(ratios.begin(), ratios.end()), Median(times), (long long)floats);
  }
  return 0;
}

struct GroupFigures {
  double samples_per_second;           // the group's, per epoch
  double alone;                        // one replica's, alone on core 0 in the same rounds
  double ratio, ratio_min, ratio_max;  // of the group's to one replica's, round by round
  double allreduce_seconds;            // one gradient all-reduce alone (median)
  long long gradient_floats;
};

// Starts `replicas` copies of this program as a group and returns rank 0's figures.
GroupFigures RunGroup(const std::string& config, int replicas, int port, int repeats) {
  std::vector<std::unique_ptr<ChildProcess>> children;
  for (int rank = 0; rank < replicas; ++rank) {
    // Rank 0's stdout carries the figures; the others' goes with the messages, to stderr.
    ChildProcess::Options options;
    options.program = kThisProgram;
    options.output = rank == 0 ? ChildProcess::Output::kPipe : ChildProcess::Output::kStderr;
    children.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{"ragdoll-bench-learner", config, "--repeats",
                                 std::to_string(repeats), "--replicas", std::to_string(replicas),
                                 "--store-port", std::to_string(port), "--rank",
                                 std::to_string(rank)},
        options));
  }
  const std::string text = children[0]->ReadOutput();
  bool ok = true;
  for (auto& child : children) ok = child->Wait() == 0 && ok;
  GroupFigures f{};
  if (!ok || std::sscanf(text.c_str(), "%lf %lf %lf %lf %lf %lf %lld", &f.samples_per_second,
                         &f.alone, &f.ratio, &f.ratio_min, &f.ratio_max, &f.allreduce_seconds,
                         &f.gradient_floats) != 7) {
    throw std::runtime_error("a learner replica failed");
  }
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  blas::ChooseKernels(argv);
  allocator::KeepLargeBlocks();
  CLI::App app("PPO update samples/s vs raw libtorch forward+backward+Adam.");
  std::string config;
  int repeats = 5, threads = 1, replicas = 1, port = 29560, rank = -1;
  app.add_option("config", config, "experiment YAML")->required();
  app.add_option("--repeats", repeats)->capture_default_str();
  app.add_option("--threads", threads, "libtorch intra-op threads")->capture_default_str();
  app.add_option("--replicas", replicas,
                 "also run a group of this many replica processes, one core and thread each "
                 "(then --threads is 1)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--store-port", port, "the group's TCPStore port")->capture_default_str();
  app.add_option("--rank", rank)->group("");  // a replica started by the benchmark itself
  CLI11_PARSE(app, argc, argv);
  try {
    run::Experiment e = run::ReadExperiment(config);
    if (rank >= 0) return RunReplica(e, rank, replicas, port, repeats);
    if (replicas > 1) {
      // Beside a group, the single learner gets what each replica gets: one core, one thread.
      PinToCore(0);
      threads = 1;
    }
    at::set_num_threads(threads);
    std::printf("%s\n", blas::Summary(true).c_str());
    const learner::TrainerConfig& c = e.trainer;
    const bench::LearnerFigures f = bench::MeasureLearner(e, repeats);
    const int64_t B = f.buffer, mb = f.minibatch;
    std::printf(
        "learner (%s, buffer %lld, minibatch %lld, %d epochs, network %d x %zu, %d "
        "thread%s, median of %d):\n",
        config.c_str(), static_cast<long long>(B), static_cast<long long>(mb), c.num_epoch,
        c.network.hidden_units.front(), c.network.hidden_units.size(), threads,
        threads == 1 ? "" : "s", repeats);
    std::printf("  raw libtorch fwd+bwd+Adam  %8.0f samples/s\n", f.raw);
    std::printf("  PPO update (per epoch)     %8.0f samples/s  ratio %.3f\n", f.update, f.ratio);
    if (replicas > 1) {
      GroupFigures g = RunGroup(config, replicas, port, repeats);
      std::printf(
          "  1 replica alone, core 0      %8.0f samples/s  (round by round with the group)\n",
          g.alone);
      std::printf(
          "  %d replicas, 1 core each     %8.0f samples/s  %.2f x one replica (median of %d "
          "rounds, %.2f-%.2f; %.2f per replica)\n",
          replicas, g.samples_per_second, g.ratio, repeats, g.ratio_min, g.ratio_max,
          g.ratio / replicas);
      // What one replica's share of a gradient step (1/N of the minibatch) takes a single
      // learner, overheads of the update included.
      const double step = static_cast<double>(mb) / replicas / g.alone;
      std::printf(
          "  gradient all-reduce alone    %8.2f ms for %lld floats; 1/%d of a minibatch takes "
          "one learner %.1f ms (%.0f %%)\n",
          1e3 * g.allreduce_seconds, g.gradient_floats, replicas, 1e3 * step,
          100 * g.allreduce_seconds / step);
    }
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "ragdoll-bench-learner: %s\n", ex.what());
    return 1;
  }
  return 0;
}
