#include "actor/evaluation.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "actor/push_evaluation.h"
#include "actor/rollout.h"

namespace ragdoll::actor {

std::string EvaluationResult::ToJson(const RobustnessResult* pushes) const {
  nlohmann::json j = {{"episodes", episodes},
                      {"mean_return", mean_return},
                      {"normalized_return", normalized_return},
                      {"episode_length", episode_length},
                      {"fall_rate", fall_rate},
                      {"reward_terms", nlohmann::json::object()}};
  for (size_t i = 0; i < figures.size(); ++i) {
    const std::string& name = spec.figure_names[i];
    if (static_cast<int>(i) < spec.reward_terms) {
      j["reward_terms"][name] = figures[i];
    } else if (spec.figure_units[i] == "rad") {
      j[spec.task][name + "_deg"] = figures[i] * 180 / M_PI;
    } else {
      j[spec.task][name] = figures[i];
    }
  }
  if (pushes) j["perturbation"] = nlohmann::json::parse(pushes->ToJson());
  return j.dump(2);
}

EvaluationResult Evaluate(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                          int episodes, uint64_t seed) {
  // One environment at a time; the rollout worker supplies the policy and normalisation.
  RolloutWorker worker(env, 1, 1, seed, "eval");
  worker.SetPolicy(snapshot);
  return Evaluate(worker, episodes);
}

EvaluationResult Evaluate(RolloutWorker& worker, int episodes) {
  EvaluationResult r;
  r.episodes = episodes;
  r.spec = worker.spec();
  r.figures.assign(r.spec.figure_names.size(), 0.0);
  for (int i = 0; i < episodes; ++i) {
    sim::EpisodeStats e = worker.RunEpisode(/*deterministic=*/true);
    r.mean_return += e.episode_return / episodes;
    r.normalized_return += e.normalized_return / episodes;
    r.episode_length += static_cast<double>(e.length) / episodes;
    r.fall_rate += (e.fell() ? 1.0 : 0.0) / episodes;
    for (size_t f = 0; f < r.figures.size(); ++f) r.figures[f] += e.figures[f] / episodes;
  }
  return r;
}

}  // namespace ragdoll::actor
