#include "eval/recovery_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "actor/rollout.h"
#include "common/config_section.h"
#include "sim/falls.h"

namespace ragdoll::eval {
namespace {

// The environment as the trials run it: no contact and no distance from the reference ends an
// episode, and none ends before the trial does.
sim::EnvConfig TrialEnvironment(sim::EnvConfig env, const character::Character& character,
                                int steps) {
  env.contacts_from_clip = false;
  env.allowed_contacts.clear();
  for (int b : character.bodies()) {
    env.allowed_contacts.push_back(mj_id2name(character.model(), mjOBJ_BODY, b));
  }
  env.max_root_distance = std::numeric_limits<double>::infinity();
  env.recovery.give_up_after = std::numeric_limits<double>::infinity();
  env.max_episode_steps = std::max(env.max_episode_steps, steps + 1);
  return env;
}

}  // namespace

RecoveryResult EvaluateRecovery(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const RecoveryConfig& config, uint64_t seed) {
  if (config.trials < 1 || !(config.seconds > 0) || !(config.hold >= 0)) {
    throw ConfigError("recovery trials need at least one trial, a positive watch and hold >= 0");
  }
  const auto character = character::Character::Load(env.character, env.physics_dt());
  const double dt = env.control_dt();
  const int steps = static_cast<int>(std::lround(config.seconds / dt));
  const int hold = static_cast<int>(std::lround(config.hold / dt));
  actor::RolloutWorker worker(TrialEnvironment(env, *character, steps), 1, 1, seed, "recovery");
  worker.SetPolicy(snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  const double stand_height = sim::StandHeight(e.clip());

  RecoveryResult result;
  result.config = config;
  std::mt19937_64 rng(seed);
  for (int t = 0; t < config.trials; ++t) {
    // Reset first: the falls are the base clip's poses, not those of where the last trial ended.
    worker.ResetFirst(std::uniform_real_distribution<double>(0, 1)(rng));
    const sim::FallenState fallen = sim::SettledFall(*character, e.clip(), rng);
    result.postures.push_back(sim::PostureName(fallen.posture));
    worker.SetStateFirst(fallen.qpos.data(), fallen.qvel.data());
    int standing = 0, up_at = -1;
    for (int s = 0; s < steps && up_at < 0; ++s) {
      const sim::StepResult step = worker.StepFirst(true);
      if (step.terminated || step.truncated) break;  // only a diverged simulation ends one
      standing = sim::PostureOf(*character, e.data(), stand_height) == sim::Posture::kStanding
                     ? standing + 1
                     : 0;
      if (standing > hold) up_at = s + 1 - standing;
    }
    result.times.push_back(up_at < 0 ? -1.0 : up_at * dt);
  }
  std::vector<double> sorted;
  for (double time : result.times) {
    sorted.push_back(time < 0 ? std::numeric_limits<double>::infinity() : time);
    result.within_5 += (time >= 0 && time <= 5) ? 1.0 / config.trials : 0;
    result.within_10 += (time >= 0 && time <= 10) ? 1.0 / config.trials : 0;
  }
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  result.median_seconds = std::isfinite(median) ? median : -1;
  return result;
}

std::string RecoveryResult::ToTable() const {
  std::map<std::string, std::pair<int, int>> by_posture;  // trials, stood
  for (size_t t = 0; t < times.size(); ++t) {
    auto& [trials, stood] = by_posture[postures[t]];
    ++trials;
    stood += times[t] >= 0 ? 1 : 0;
  }
  std::ostringstream out;
  char median[32] = "never", line[160];
  if (median_seconds >= 0) std::snprintf(median, sizeof(median), "%.2f s", median_seconds);
  std::snprintf(line, sizeof(line),
                "recovery from %d settled falls (watch %.0f s, standing %.1f s counts):\n"
                "  standing within 5 s %.0f %%, within 10 s %.0f %%, median time %s\n",
                config.trials, config.seconds, config.hold, 100 * within_5, 100 * within_10,
                median);
  out << line;
  for (const auto& [posture, counts] : by_posture) {
    std::snprintf(line, sizeof(line), "  %-10s %3d trials, %3d stood\n", posture.c_str(),
                  counts.first, counts.second);
    out << line;
  }
  return out.str();
}

std::string RecoveryResult::ToJson() const {
  nlohmann::json j = {{"trials", config.trials}, {"seconds", config.seconds},
                      {"hold", config.hold},     {"within_5", within_5},
                      {"within_10", within_10},  {"median_seconds", median_seconds},
                      {"times", times},          {"postures", postures}};
  return j.dump(2);
}

}  // namespace ragdoll::eval
