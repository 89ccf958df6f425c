#include "eval/push_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "actor/rollout.h"
#include "character/rotation.h"
#include "common/config_section.h"
#include "eval/scripted_pushes.h"

namespace ragdoll::eval {
namespace {

// Survived in at least 90 % of the trials: the one criterion of the sweep and the protocol.
bool Survived(int falls, int trials) { return falls * 10 <= trials; }

// Trials a step that keep the protocol's figures steady across seeds (docs/tools.md).
constexpr int kSteadyTrials = 100;

void CheckDirection(const std::string& direction, bool random_allowed) {
  double side = 0;
  if ((random_allowed && direction == "random") || SideAngle(direction, &side)) return;
  throw ConfigError("push direction '" + direction + "': one of " +
                    (random_allowed ? "random, " : "") + "forward, backward, left, right");
}

// The trials of one evaluation: a policy in one environment, the start phases and random angles
// drawn once, so that every impulse and direction meets the same situations.
class PushTrials {
 public:
  PushTrials(sim::EnvConfig env, const v1::PolicySnapshot& snapshot, const std::string& body,
             const std::string& command, double duration, double settle, double observe, int trials,
             uint64_t seed)
      : worker_(Unleashed(env), 1, 1, seed, "push") {
    if (!(duration > 0) || !(settle >= 0) || !(observe > 0) || trials < 1) {
      throw ConfigError(
          "pushes need a positive duration and watch, a settle time >= 0 and at "
          "least one trial");
    }
    sim::ImitationEnv& e = worker_.environment(0);
    body_ = mj_name2id(e.character().model(), mjOBJ_BODY, body.c_str());
    if (body_ < 1) throw ConfigError("push body '" + body + "' is not in the character");
    if (!command.empty()) {
      const sim::MotionSet& motions = e.motion_set();
      command_ = env.steering.enabled() ? motions.Find(command) : -1;
      if (command_ < 0 || motions.entry(command_).transition() || motions.entry(command_).get_up) {
        throw ConfigError("push command '" + command + "': not a command of the run's motion set" +
                          (env.steering.enabled() ? "" : " (it has no steering task)"));
      }
    }
    worker_.SetPolicy(snapshot);
    const double dt = env.control_dt();
    settle_ = static_cast<int>(std::lround(settle / dt));
    pushing_ = std::max(1, static_cast<int>(std::lround(duration / dt)));
    observe_ = static_cast<int>(std::lround(observe / dt));
    push_seconds_ = pushing_ * dt;
    // Start phases that leave room for the whole trial in a clip that does not loop.
    const double span = (settle_ + pushing_ + observe_) * dt;
    const double max_phase =
        e.clip().loop() ? 1.0 : std::max(0.0, 1.0 - span / std::max(e.clip().duration(), 1e-9));
    std::mt19937_64 rng(seed);
    for (int t = 0; t < trials; ++t) {
      phases_.push_back(std::uniform_real_distribution<double>(0, max_phase)(rng));
      angles_.push_back(std::uniform_real_distribution<double>(-M_PI, M_PI)(rng));
    }
  }

  int trials() const { return static_cast<int>(phases_.size()); }
  double mass() { return worker_.environment(0).character().total_mass(); }

  // Every trial pushed with `impulse` toward `direction`; `falls` counts those that fell.
  PushResult Run(double impulse, const std::string& direction, int* falls) {
    PushResult r;
    r.impulse = impulse;
    r.force = impulse / push_seconds_;
    *falls = 0;
    for (int t = 0; t < trials(); ++t) {
      *falls += Trial(t, r.force, direction) ? 1 : 0;
      const sim::EpisodeStats& e = worker_.environment(0).episode();
      r.normalized_return +=
          e.episode_return / (worker_.spec().max_reward_per_step * std::max(e.length, 1));
    }
    r.fall_rate = static_cast<double>(*falls) / trials();
    r.normalized_return /= trials();
    return r;
  }

  // Whether the character survives `impulse` in at least 90 % of the trials (stops as soon as
  // too many have fallen).
  bool Survives(double impulse, const std::string& direction) {
    int falls = 0;
    for (int t = 0; t < trials() && Survived(falls, trials()); ++t) {
      falls += Trial(t, impulse / push_seconds_, direction) ? 1 : 0;
    }
    return Survived(falls, trials());
  }

 private:
  // Straying from the reference ends no trial: only a fall does.
  static sim::EnvConfig Unleashed(sim::EnvConfig env) {
    env.max_root_distance = std::numeric_limits<double>::infinity();
    return env;
  }

  // Trial t with a push of `force` newtons toward `direction`: whether the character fell.
  bool Trial(int t, double force, const std::string& direction) {
    sim::ImitationEnv& e = worker_.environment(0);
    if (command_ >= 0) worker_.SetCommandFirst(command_);
    worker_.ResetFirst(phases_[t]);
    bool ended = false;
    for (int s = 0; s < settle_ + pushing_ + observe_ && !ended; ++s) {
      if (s == settle_) {
        double angle = angles_[t];
        if (direction != "random") {
          const double* q = e.data().xquat + 4 * e.character().root_body();
          SideAngle(direction, &angle);  // checked before any trial
          angle += character::YawOf({q[0], q[1], q[2], q[3]});
        }
        e.SetExternalForce(body_, {force * std::cos(angle), force * std::sin(angle), 0});
      }
      if (s == settle_ + pushing_) e.SetExternalForce(body_, {0, 0, 0});
      const sim::StepResult step = worker_.StepFirst(true);
      // A policy that gets up (EnvConfig::recovery) fell without the episode ending.
      ended = step.terminated || step.truncated || e.episode().fell();
    }
    return e.episode().fell();
  }

  actor::RolloutWorker worker_;
  int body_ = 0;
  int command_ = -1;  // held through each trial; -1: training's random commands
  int settle_ = 0, pushing_ = 0, observe_ = 0;
  double push_seconds_ = 0;
  std::vector<double> phases_, angles_;
};

}  // namespace

RobustnessResult EvaluatePushes(const sim::EnvConfig& env, const v1::PolicySnapshot& snapshot,
                                const PushConfig& push, uint64_t seed) {
  CheckDirection(push.direction, true);
  if (push.impulses.empty()) throw ConfigError("pushes need at least one impulse");
  PushTrials trials(env, snapshot, push.body, push.command, push.duration, push.settle,
                    push.observe, push.trials, seed);
  RobustnessResult result;
  result.config = push;
  bool all_survived_so_far = true;
  for (double impulse : push.impulses) {
    int falls = 0;
    PushResult r = trials.Run(impulse, push.direction, &falls);
    if (all_survived_so_far && Survived(falls, trials.trials())) {
      result.survived_90 = impulse;
    } else {
      all_survived_so_far = false;
    }
    result.results.push_back(r);
  }
  return result;
}

PushProtocolResult EvaluatePushProtocol(const sim::EnvConfig& env,
                                        const v1::PolicySnapshot& snapshot,
                                        const PushProtocolConfig& protocol, uint64_t seed) {
  for (const auto& d : protocol.directions) CheckDirection(d, false);
  if (!(protocol.start > 0) || !(protocol.max_impulse >= protocol.start) ||
      !(protocol.resolution > 0)) {
    throw ConfigError("the push search needs 0 < start <= max impulse and a positive resolution");
  }
  PushTrials trials(env, snapshot, protocol.body, protocol.command, protocol.duration,
                    protocol.settle, protocol.observe, protocol.trials, seed);
  PushProtocolResult result;
  result.config = protocol;
  result.mass = trials.mass();
  for (const auto& direction : protocol.directions) {
    DirectionResult d;
    d.direction = direction;
    auto survives = [&](double impulse) {
      ++d.impulses_tried;
      return trials.Survives(impulse, direction);
    };
    double passed = 0, failed = protocol.start;
    while (!d.at_limit && survives(failed)) {
      passed = failed;
      d.at_limit = failed >= protocol.max_impulse;
      failed = std::min(2 * failed, protocol.max_impulse);
    }
    while (!d.at_limit && failed - passed > protocol.resolution) {
      const double middle = 0.5 * (passed + failed);
      (survives(middle) ? passed : failed) = middle;
    }
    d.survived_90 = passed;
    d.velocity_change = passed / result.mass;
    result.directions.push_back(d);
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

std::string PushProtocolResult::ToTable() const {
  std::ostringstream out;
  char line[200];
  std::snprintf(line, sizeof(line),
                "DeepMimic's protocol: pushes on %s for %.2f s, %d trials each (settle %.1f s, "
                "watch %.1f s), %.1f kg%s%s\n",
                config.body.c_str(), config.duration, config.trials, config.settle, config.observe,
                mass, config.command.empty() ? "" : ", command ", config.command.c_str());
  out << line << "  direction   survived in >= 90 %   velocity change   impulses tried\n";
  for (const auto& d : directions) {
    std::snprintf(line, sizeof(line), "  %-9s   %s%7.1f N s   %10.2f m/s   %8d\n",
                  d.direction.c_str(), d.at_limit ? ">=" : "  ", d.survived_90, d.velocity_change,
                  d.impulses_tried);
    out << line;
  }
  // Near a policy's 90 % point "at least 90 % of 20" is close to a coin toss at each step.
  if (config.trials < kSteadyTrials) {
    std::snprintf(line, sizeof(line),
                  "  %d trials a step: figures can move by tens of N s with --seed; near a target "
                  "use --push-trials %d (docs/tools.md)\n",
                  config.trials, kSteadyTrials);
    out << line;
  }
  return out.str();
}

std::string PushProtocolResult::ToJson() const {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& d : directions) {
    list.push_back({{"direction", d.direction},
                    {"survived_90", d.survived_90},
                    {"velocity_change", d.velocity_change},
                    {"at_limit", d.at_limit},
                    {"impulses_tried", d.impulses_tried}});
  }
  nlohmann::json j = {{"body", config.body},
                      {"duration", config.duration},
                      {"trials", config.trials},
                      {"settle", config.settle},
                      {"observe", config.observe},
                      {"resolution", config.resolution},
                      {"max_impulse", config.max_impulse},
                      {"mass", mass},
                      {"directions", list}};
  if (!config.command.empty()) j["command"] = config.command;
  return j.dump(2);
}

}  // namespace ragdoll::eval
