#include "eval/evaluation.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "actor/rollout.h"
#include "character/character.h"
#include "eval/push_evaluation.h"
#include "sim/motion_set.h"

namespace ragdoll::eval {

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
  actor::RolloutWorker worker(env, 1, 1, seed, "eval");
  worker.SetPolicy(snapshot);
  return Evaluate(worker, episodes);
}

namespace {

// Means over `episodes` episodes that `run` plays one at a time.
template <typename RunEpisode>
EvaluationResult Mean(const sim::EnvSpec& spec, int episodes, RunEpisode run) {
  EvaluationResult r;
  r.episodes = episodes;
  r.spec = spec;
  r.figures.assign(r.spec.figure_names.size(), 0.0);
  for (int i = 0; i < episodes; ++i) {
    const sim::EpisodeStats e = run();
    r.mean_return += e.episode_return / episodes;
    r.normalized_return += e.normalized_return / episodes;
    r.episode_length += static_cast<double>(e.length) / episodes;
    r.fall_rate += (e.fell() ? 1.0 : 0.0) / episodes;
    for (size_t f = 0; f < r.figures.size(); ++f) r.figures[f] += e.figures[f] / episodes;
  }
  return r;
}

}  // namespace

EvaluationResult Evaluate(actor::RolloutWorker& worker, int episodes) {
  return Mean(worker.spec(), episodes, [&] { return worker.RunEpisode(/*deterministic=*/true); });
}

EvaluationResult EvaluateReferenceTracking(const sim::EnvConfig& config, int episodes,
                                           uint64_t seed) {
  auto character = character::Character::Load(config.character, config.physics_dt());
  sim::ImitationEnv env(character, sim::LoadMotionSet(config, *character), config, seed);
  std::vector<float> observation(env.spec().observation_size), action(env.spec().action_size);
  return Mean(env.spec(), episodes, [&] {
    env.Reset(observation.data());
    for (;;) {
      env.ReferenceAction(action.data());
      const sim::StepResult s = env.Step(action.data(), observation.data());
      if (s.terminated || s.truncated) return env.episode();
    }
  });
}

}  // namespace ragdoll::eval
