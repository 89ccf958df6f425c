#include "actor/evaluation.h"

#include <nlohmann/json.hpp>

#include "actor/rollout.h"

namespace ragdoll::actor {

std::string EvaluationResult::ToJson() const {
  nlohmann::json j = {{"episodes", episodes},
                      {"mean_return", mean_return},
                      {"normalized_return", normalized_return},
                      {"episode_length", episode_length},
                      {"fall_rate", fall_rate},
                      {"reward_terms",
                       {{"rotation", rotation},
                        {"velocity", velocity},
                        {"end_effector", end_effector},
                        {"com", com},
                        {"root", root}}}};
  return j.dump(2);
}

EvaluationResult Evaluate(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                          int episodes, uint64_t seed) {
  // One environment at a time; the rollout worker supplies the policy and normalisation.
  RolloutWorker worker(env, 1, 1, seed, "eval");
  worker.SetPolicy(snapshot);
  EvaluationResult r;
  r.episodes = episodes;
  for (int i = 0; i < episodes; ++i) {
    sim::EpisodeStats e = worker.RunEpisode(/*deterministic=*/true);
    r.mean_return += e.episode_return / episodes;
    r.normalized_return += e.normalized_return / episodes;
    r.episode_length += static_cast<double>(e.length) / episodes;
    r.fall_rate += (e.fell() ? 1.0 : 0.0) / episodes;
    r.rotation += e.mean_terms.rotation / episodes;
    r.velocity += e.mean_terms.velocity / episodes;
    r.end_effector += e.mean_terms.end_effector / episodes;
    r.com += e.mean_terms.com / episodes;
    r.root += e.mean_terms.root / episodes;
  }
  return r;
}

}  // namespace ragdoll::actor
