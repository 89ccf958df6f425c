// Records real rollouts of a trained policy for checking an exported ONNX model against libtorch:
// the observations the environment builds, the actions the actor's libtorch policy computes for
// them (deterministic: the mean), and the critic's values.
//   record_rollouts RUN_OR_CHECKPOINT STEPS OUT_FOLDER [SEED]
// writes OUT_FOLDER/observations.f32 [STEPS, obs], actions.f32 [STEPS, act] and values.f32
// [STEPS] (float32, little-endian, row-major). Episodes restart at random clip phases until STEPS
// control steps have been recorded.
#include <torch/torch.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "actor/rollout.h"
#include "common/policy.h"
#include "common/running_stats.h"
#include "run/trained_policy.h"
#include "sim/observation.h"

namespace {

void Write(const std::filesystem::path& path, const std::vector<float>& values) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(values.data()),
            static_cast<std::streamsize>(values.size() * sizeof(float)));
  if (!out.flush()) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ragdoll;
  if (argc < 4) {
    std::fprintf(stderr, "usage: record_rollouts RUN_OR_CHECKPOINT STEPS OUT_FOLDER [SEED]\n");
    return 2;
  }
  try {
    const int steps = std::atoi(argv[2]);
    const std::filesystem::path out = argv[3];
    const uint64_t seed = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 1;
    run::TrainedPolicy p = run::LoadTrainedPolicy(argv[1]);
    actor::RolloutWorker worker(p.experiment.environment, 1, 1, seed, "recorder");
    worker.SetPolicy(p.snapshot);
    sim::ImitationEnv& env = worker.environment(0);
    const int O = worker.spec().observation_size, A = worker.spec().action_size;
    const RunningStats stats = StatsFromSnapshot(p.snapshot);
    GaussianPolicy policy = PolicyFromSnapshot(p.snapshot);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> phase(0.0, 1.0);

    std::vector<float> observations, actions, values;
    std::vector<float> observation(O), normalized(O), action, log_probs;
    int episodes = 1, mismatches = 0;
    worker.ResetFirst(phase(rng));
    for (int t = 0; t < steps; ++t) {
      // The observation the worker holds, rebuilt from the same state by the same function.
      sim::BuildObservation(env.character(), env.data(), env.phase(), observation.data());
      worker.Act(true, &action, &log_probs);
      // The worker's action must be the policy's on the rebuilt observation, bit for bit, or the
      // rebuilt observation is not the one the actor used.
      stats.Normalize(observation.data(), 1, normalized.data());
      torch::InferenceMode inference;
      torch::Tensor z = torch::from_blob(normalized.data(), {1, O});
      torch::Tensor mean = policy->forward(z).contiguous();
      for (int a = 0; a < A; ++a) mismatches += mean.data_ptr<float>()[a] != action[a];
      const double critic = p.critic->forward(z).item<double>();
      observations.insert(observations.end(), observation.begin(), observation.end());
      actions.insert(actions.end(), action.begin(), action.end());
      values.push_back(static_cast<float>(critic * p.value_scale + p.value_offset));
      sim::StepResult r = worker.StepFirst(true);
      if (r.terminated || r.truncated) {
        worker.ResetFirst(phase(rng));
        if (t + 1 < steps) ++episodes;
      }
    }
    if (mismatches > 0) {
      std::fprintf(stderr, "record_rollouts: %d actions differ from the actor's\n", mismatches);
      return 1;
    }
    std::filesystem::create_directories(out);
    Write(out / "observations.f32", observations);
    Write(out / "actions.f32", actions);
    Write(out / "values.f32", values);
    std::printf(
        "recorded %d steps in %d episodes (observation %d, action %d) from %s (policy v%lld)\n",
        steps, episodes, O, A, p.checkpoint.c_str(), static_cast<long long>(p.version));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "record_rollouts: %s\n", e.what());
    return 1;
  }
}
