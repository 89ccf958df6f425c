#include "actor/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "actor/rollout.h"
#include "common/config_section.h"

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

namespace ragdoll::actor {

RobustnessResult EvaluatePushes(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const PushConfig& push, uint64_t seed) {
  const std::vector<std::string> directions = {"random", "forward", "backward", "left", "right"};
  if (std::find(directions.begin(), directions.end(), push.direction) == directions.end()) {
    throw ConfigError("push direction '" + push.direction +
                      "': one of random, forward, backward, left, right");
  }
  if (!(push.duration > 0) || push.trials < 1 || push.impulses.empty()) {
    throw ConfigError("pushes need a positive duration, at least one trial and one impulse");
  }
  RolloutWorker worker(env, 1, 1, seed, "push");
  worker.SetPolicy(snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  const sim::Character& character = e.character();
  const int body = mj_name2id(character.model(), mjOBJ_BODY, push.body.c_str());
  if (body < 1) throw ConfigError("push body '" + push.body + "' is not in the character");
  const double dt = env.control_dt();
  const int settle = static_cast<int>(std::lround(push.settle / dt));
  const int pushing = std::max(1, static_cast<int>(std::lround(push.duration / dt)));
  const int observe = static_cast<int>(std::lround(push.observe / dt));
  // Start phases that leave room for the whole trial in a clip that does not loop.
  const double span = (settle + pushing + observe) * dt;
  const double clip_duration = e.clip().duration();
  const double max_phase =
      e.clip().loop() ? 1.0 : std::max(0.0, 1.0 - span / std::max(clip_duration, 1e-9));
  std::mt19937_64 rng(seed);
  std::vector<double> phases, angles;
  for (int t = 0; t < push.trials; ++t) {
    phases.push_back(std::uniform_real_distribution<double>(0, max_phase)(rng));
    angles.push_back(std::uniform_real_distribution<double>(-M_PI, M_PI)(rng));
  }
  const std::map<std::string, double> fixed = {
      {"forward", 0}, {"left", M_PI / 2}, {"backward", M_PI}, {"right", -M_PI / 2}};

  RobustnessResult result;
  result.config = push;
  bool all_survived_so_far = true;
  for (double impulse : push.impulses) {
    PushResult r;
    r.impulse = impulse;
    r.force = impulse / (pushing * dt);
    int falls = 0;
    for (int t = 0; t < push.trials; ++t) {
      worker.ResetFirst(phases[t]);
      bool fell = false, ended = false;
      for (int s = 0; s < settle + pushing + observe && !ended; ++s) {
        if (s == settle) {
          // The direction in the character's heading frame (or a random world direction).
          double angle = push.direction == "random" ? angles[t] : fixed.at(push.direction);
          if (push.direction != "random") {
            const double* q = e.data().xquat + 4 * character.root_body();
            angle += sim::YawOf({q[0], q[1], q[2], q[3]});
          }
          e.SetExternalForce(body, {r.force * std::cos(angle), r.force * std::sin(angle), 0});
        }
        if (s == settle + pushing) e.SetExternalForce(body, {0, 0, 0});
        sim::StepResult step = worker.StepFirst(true);
        if (step.terminated || step.truncated) {
          ended = true;
          fell = e.episode().fell();
        }
      }
      falls += fell ? 1 : 0;
      r.normalized_return += e.episode().episode_return /
                             (e.spec().max_reward_per_step * std::max(e.episode().length, 1)) /
                             push.trials;
    }
    r.fall_rate = static_cast<double>(falls) / push.trials;
    if (all_survived_so_far && falls * 10 <= push.trials) {
      result.survived_90 = impulse;
    } else {
      all_survived_so_far = false;
    }
    result.results.push_back(r);
  }
  return result;
}

std::string RobustnessResult::ToTable() const {
  std::ostringstream out;
  char line[160];
  std::snprintf(
      line, sizeof(line),
      "pushes on %s for %.2f s, %s direction, %d trials each (settle %.1f s, watch %.1f s)\n",
      config.body.c_str(), config.duration, config.direction.c_str(), config.trials, config.settle,
      config.observe);
  out << line << "  impulse N s   force N   fall rate   normalised return\n";
  for (const auto& r : results) {
    std::snprintf(line, sizeof(line), "  %9.1f  %8.0f   %8.2f   %10.3f\n", r.impulse, r.force,
                  r.fall_rate, r.normalized_return);
    out << line;
  }
  if (survived_90 >= 0) {
    std::snprintf(line, sizeof(line), "  largest push survived in >= 90 %% of trials: %.1f N s\n",
                  survived_90);
  } else {
    std::snprintf(line, sizeof(line), "  no push survived in >= 90 %% of trials\n");
  }
  out << line;
  return out.str();
}

std::string RobustnessResult::ToJson() const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& r : results) {
    list.push_back({{"impulse", r.impulse},
                    {"force", r.force},
                    {"fall_rate", r.fall_rate},
                    {"normalized_return", r.normalized_return}});
  }
  nlohmann::json j = {
      {"body", config.body},     {"duration", config.duration}, {"direction", config.direction},
      {"trials", config.trials}, {"settle", config.settle},     {"observe", config.observe},
      {"results", list},         {"survived_90", survived_90}};
  return j.dump(2);
}

}  // namespace ragdoll::actor
