#include "actor/command_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "actor/rollout.h"
#include "actor/sim/steering_task.h"
#include "common/config_section.h"

namespace ragdoll::actor {
namespace {

// Sums of one command's (or transition's) scored steps.
struct Sums {
  double steps = 0, speed = 0, heading = 0, imitation = 0;
  void Add(double s, double h, double i) {
    ++steps;
    speed += s;
    heading += h;
    imitation += i;
  }
  void AddTo(CommandTracking* t, double dt) const {
    // Running means weighted by time.
    double total = t->seconds + steps * dt;
    if (total <= 0) return;
    auto mix = [&](double mean, double sum) { return (mean * t->seconds + sum * dt) / total; };
    t->speed_error = mix(t->speed_error, speed);
    t->heading_error = mix(t->heading_error, heading);
    t->imitation = mix(t->imitation, imitation);
    t->seconds = total;
  }
};

nlohmann::json TrackingJson(const CommandTracking& t) {
  return {{"seconds", t.seconds},
          {"speed_error", t.speed_error},
          {"heading_error_deg", t.heading_error * 180 / M_PI},
          {"imitation", t.imitation}};
}

}  // namespace

CommandScript ReadCommandScript(const std::string& path, const sim::MotionSet& motions,
                                const sim::Character& character) {
  ConfigSection root = ConfigSection::FromFile(path);
  CommandScript script;
  for (const ConfigSection& c : root.SectionList("commands")) {
    CommandScript::Change change;
    change.at = c.Get<double>("at", -1.0);
    change.command = c.Get<std::string>("command", "");
    int entry = motions.Find(change.command);
    if (entry < 0 || motions.entry(entry).transition()) {
      std::string known;
      for (int i : motions.commands()) known += (known.empty() ? "" : ", ") + motions.entry(i).name;
      c.Fail("command",
             "'" + change.command + "' is not a command of the run's motion set (" + known + ")");
    }
    if (!std::isfinite(change.at) || change.at < 0) c.Fail("at", "must be a time >= 0, s");
    if (script.changes.empty() && change.at != 0) c.Fail("at", "the first command starts at 0");
    if (!script.changes.empty() && change.at <= script.changes.back().at) {
      c.Fail("at", "times must increase");
    }
    c.Finish();
    script.changes.push_back(change);
  }
  if (script.changes.empty()) root.Fail("commands", "required: at least one {at, command}");
  for (const ConfigSection& c : root.SectionList("pushes")) {
    TimedPush push;
    push.at = c.Get<double>("at", -1.0);
    push.impulse = c.Get<double>("impulse", -1.0);
    push.direction = c.Get<std::string>("direction", push.direction);
    push.duration = c.Get<double>("duration", push.duration);
    push.body = c.Get<std::string>("body", "");
    if (!std::isfinite(push.at) || push.at < 0) c.Fail("at", "must be a time >= 0, s");
    if (!std::isfinite(push.impulse) || push.impulse < 0 || push.impulse > 10000) {
      c.Fail("impulse", "must be 0-10000 N s");
    }
    if (double side; !SideAngle(push.direction, &side)) {
      c.Fail("direction", "'" + push.direction + "': one of forward, backward, left, right");
    }
    if (!std::isfinite(push.duration) || push.duration <= 0 || push.duration > 10) {
      c.Fail("duration", "must be 0-10 s");
    }
    if (!push.body.empty() && mj_name2id(character.model(), mjOBJ_BODY, push.body.c_str()) < 1) {
      c.Fail("body", "'" + push.body + "' is not a body of the character");
    }
    if (!script.pushes.empty() &&
        push.at < script.pushes.back().at + script.pushes.back().duration) {
      c.Fail("at", "pushes must come in time order, each after the previous one has ended");
    }
    c.Finish();
    script.pushes.push_back(push);
  }
  script.duration = root.Get<double>("duration", script.changes.back().at + 5.0);
  if (!(script.duration > script.changes.back().at)) {
    root.Fail("duration", "must be after the last command's time");
  }
  root.Finish();
  return script;
}

CommandScript RandomCommandScript(const sim::MotionSet& motions, double duration,
                                  double interval_min, double interval_max, uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::vector<int>& commands = motions.commands();
  std::uniform_int_distribution<size_t> pick(0, commands.size() - 1);
  std::uniform_real_distribution<double> interval(interval_min, interval_max);
  CommandScript script;
  script.duration = duration;
  int current = commands[pick(rng)];
  for (double t = 0; t < duration; t += interval(rng)) {
    script.changes.push_back({t, motions.entry(current).name});
    if (commands.size() > 1) {
      int next = current;
      while (next == current) next = commands[pick(rng)];
      current = next;
    }
  }
  return script;
}

KnockDownClock::KnockDownClock(double speed_tolerance, double heading_tolerance, double hold)
    : speed_tolerance_(speed_tolerance), heading_tolerance_(heading_tolerance), hold_(hold) {}

void KnockDownClock::Pushed(double t) { pushed_ = t; }

void KnockDownClock::Step(double t, bool fell, bool getting_up, double speed_error,
                          double heading_error) {
  const double began = previous_;  // the step's start: its tracking counts from there
  previous_ = t;
  if (fell && down_since_ < 0) down_since_ = t - pushed_ <= kPushToFall ? pushed_ : t;
  if (down_since_ < 0) return;
  const bool tracking = !fell && !getting_up && speed_error <= speed_tolerance_ &&
                        heading_error <= heading_tolerance_;
  if (!tracking) {
    good_since_ = -1;
    return;
  }
  if (good_since_ < 0) good_since_ = began;
  if (t - good_since_ >= hold_ - 1e-9) {
    seconds_.push_back(good_since_ - down_since_);
    down_since_ = good_since_ = -1;
  }
}

void KnockDownClock::End(double t, double window, bool gave_up) {
  if (gave_up || (down_since_ >= 0 && t - down_since_ >= window)) {
    seconds_.push_back(std::numeric_limits<double>::infinity());
  }
  down_since_ = good_since_ = -1;
}

int CommandEvalResult::back_within() const {
  return static_cast<int>(std::count_if(knockdown_seconds.begin(), knockdown_seconds.end(),
                                        [&](double s) { return s <= back_window; }));
}

double CommandEvalResult::median_back_seconds() const {
  if (knockdown_seconds.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> sorted = knockdown_seconds;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  return n % 2 ? sorted[n / 2] : (sorted[n / 2 - 1] + sorted[n / 2]) / 2;
}

CommandEvalResult EvaluateCommands(const sim::EnvConfig& env_config,
                                   const v1::PolicySnapshot& snapshot,
                                   const CommandEvalConfig& config, uint64_t seed) {
  if (!env_config.steering.enabled()) {
    throw std::invalid_argument("--commands needs a run trained with a steering task");
  }
  sim::EnvConfig env = env_config;
  const double dt = env.control_dt();
  const double longest = config.random ? config.duration : config.script.duration;
  env.max_episode_steps = static_cast<int>(std::ceil(longest / dt)) + 1;
  env.random_start = true;
  // A push that only carries the character away from its reference is not a fall.
  if (config.push_interval > 0) env.max_root_distance = std::numeric_limits<double>::infinity();
  RolloutWorker worker(env, 1, 1, seed, "commands");
  worker.SetPolicy(snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  const sim::SteeringTask& steering = sim::Steering(e);
  const sim::MotionSet& motions = e.motion_set();
  const double imitation_max = env.reward.MaxReward();
  std::mt19937_64 phases(seed);

  CommandEvalResult result;
  result.back_window = config.back_window;
  std::map<std::string, Sums> per_command;
  Sums overall, moving;
  for (int run = 0; run < config.runs; ++run) {
    const CommandScript script =
        config.random
            ? RandomCommandScript(motions, config.duration, env.steering.command_interval_min,
                                  env.steering.command_interval_max, seed + 1 + run)
            : config.script;
    worker.SetCommandFirst(motions.Find(script.changes.front().command));
    worker.ResetFirst(std::uniform_real_distribution<double>(0, 1)(phases));
    ScriptedPushes scripted(script.pushes, e.character());
    RandomPushes random_pushes(0, config.push_max, config.push_interval, dt, seed + 1 + run,
                               e.character().root_body());
    KnockDownClock knockdowns(config.transition_speed, config.transition_heading, config.back_hold);
    ++result.runs;
    size_t next = 1;
    double changed_at = 0;
    std::string previous;  // the command before the last change
    // The pending transition's scoring: from settle until the window ends or the next change.
    Sums transition;
    bool pending = false;
    auto close_transition = [&](bool fell) {
      if (!pending) return;
      pending = false;
      if (!fell && transition.steps == 0) return;  // the next change came before it settled
      TransitionOutcome& o =
          result.transitions[previous + "->" + e.motion_set().entry(steering.command_entry()).name];
      ++o.count;
      if (!fell && transition.speed / transition.steps <= config.transition_speed &&
          transition.heading / transition.steps <= config.transition_heading) {
        ++o.succeeded;
      }
    };
    const int steps = static_cast<int>(std::lround(script.duration / dt));
    bool fell = false, knocked = false;
    double run_time = 0;
    for (int step = 0; step < steps && !fell; ++step) {
      const double t = step * dt;
      run_time = t + dt;
      if (next < script.changes.size() && t >= script.changes[next].at - 1e-9) {
        close_transition(false);
        previous = motions.entry(steering.command_entry()).name;
        worker.SetCommandFirst(motions.Find(script.changes[next].command));
        changed_at = t;
        pending = true;
        transition = Sums();
        ++next;
      }
      if (scripted.Before(e, t)) {
        ++result.pushes;
        knockdowns.Pushed(t);
      }
      if (random_pushes.Before(e, step)) {
        ++result.pushes;
        knockdowns.Pushed(t);
      }
      const int falls_before = e.episode().task_falls;
      sim::StepResult r = worker.StepFirst(/*deterministic=*/true);
      result.seconds += dt;
      if (!r.terminated) {
        knockdowns.Step(t + dt, e.episode().task_falls > falls_before,
                        motions.entry(e.reference_entry()).get_up, steering.SpeedError(),
                        std::abs(steering.HeadingError(e)));
      }
      knocked = knocked || r.terminated || e.episode().fell();
      if (r.terminated) {
        fell = true;
        ++result.falls;
        close_transition(true);
        break;
      }
      // Getting up (EnvConfig::recovery) is scored by --recovery, not as steering.
      if (motions.entry(e.reference_entry()).get_up) continue;
      const double since = t + dt - changed_at;
      if (since < config.settle) continue;
      const double speed = steering.SpeedError(), heading = std::abs(steering.HeadingError(e));
      if (pending) {
        if (since <= config.transition_window) {
          transition.Add(speed, heading, 0);
        } else {
          close_transition(false);
        }
      }
      if (motions.entry(e.reference_entry()).transition()) continue;
      const double imitation = (r.terms.total - r.terms.task) / imitation_max;
      const sim::Command& c = steering.command();
      per_command[motions.entry(steering.command_entry()).name].Add(speed, heading, imitation);
      overall.Add(speed, heading, imitation);
      if (std::hypot(c.forward, c.left) > 0.1 || std::abs(c.turn) > 0.1) {
        moving.Add(speed, heading, imitation);
      }
    }
    if (!fell) close_transition(false);
    if (knocked) ++result.knocked_down;
    // Without recovery every fall ends the run: the fall rate says it all.
    if (env.recovery.enabled()) {
      knockdowns.End(run_time, config.back_window, fell);
      result.knockdown_seconds.insert(result.knockdown_seconds.end(), knockdowns.seconds().begin(),
                                      knockdowns.seconds().end());
    }
  }
  overall.AddTo(&result.overall, dt);
  moving.AddTo(&result.moving, dt);
  for (const auto& [name, sums] : per_command) sums.AddTo(&result.per_command[name], dt);
  return result;
}

std::string CommandEvalResult::ToTable() const {
  std::ostringstream out;
  char line[256];
  auto row = [&](const std::string& name, const CommandTracking& t) {
    std::snprintf(line, sizeof line, "  %-16s %8.1f %10.3f %10.1f %10.3f\n", name.c_str(),
                  t.seconds, t.speed_error, t.heading_error * 180 / M_PI, t.imitation);
    out << line;
  };
  std::snprintf(line, sizeof line,
                "commands: %d runs, %.0f s simulated, fall rate %.3f (%d runs fell)\n", runs,
                seconds, fall_rate(), falls);
  out << line;
  if (pushes > 0 || knocked_down > falls) {
    std::snprintf(line, sizeof line,
                  "  %d pushes; %d runs knocked down, %d of them did not get up\n", pushes,
                  knocked_down, falls);
    out << line;
  }
  if (!knockdown_seconds.empty()) {
    char median[32] = "never";
    if (std::isfinite(median_back_seconds())) {
      std::snprintf(median, sizeof median, "%.2f s", median_back_seconds());
    }
    std::snprintf(line, sizeof line,
                  "  %zu knock-downs, back on command within %.0f s: %d (%.2f), median %s\n",
                  knockdown_seconds.size(), back_window, back_within(),
                  static_cast<double>(back_within()) / knockdown_seconds.size(), median);
    out << line;
  }
  out << "  command           settled  speed err  heading°   imitation\n";
  for (const auto& [name, t] : per_command) row(name, t);
  row("(moving)", moving);
  row("(all)", overall);
  out << "  transition                  count  succeeded\n";
  for (const auto& [kind, o] : transitions) {
    std::snprintf(line, sizeof line, "  %-26s %6d %10.2f\n", kind.c_str(), o.count,
                  o.count ? static_cast<double>(o.succeeded) / o.count : 0.0);
    out << line;
  }
  return out.str();
}

std::string CommandEvalResult::ToJson() const {
  nlohmann::json j = {{"runs", runs},
                      {"falls", falls},
                      {"fall_rate", fall_rate()},
                      {"knocked_down", knocked_down},
                      {"pushes", pushes},
                      {"seconds", seconds},
                      {"overall", TrackingJson(overall)},
                      {"moving", TrackingJson(moving)}};
  if (!knockdown_seconds.empty()) {
    const double median = median_back_seconds();
    j["knockdowns"] = {
        {"count", knockdown_seconds.size()},
        {"back_window", back_window},
        {"back_within", back_within()},
        {"share_back_within", static_cast<double>(back_within()) / knockdown_seconds.size()},
        // JSON has no infinity: null for never back (the median: when half or more never were).
        {"median_seconds", std::isfinite(median) ? nlohmann::json(median) : nlohmann::json()}};
    nlohmann::json& times = j["knockdowns"]["seconds"] = nlohmann::json::array();
    for (double t : knockdown_seconds) {
      times.push_back(std::isfinite(t) ? nlohmann::json(t) : nlohmann::json());
    }
  }
  for (const auto& [name, t] : per_command) j["per_command"][name] = TrackingJson(t);
  for (const auto& [kind, o] : transitions) {
    j["transitions"][kind] = {{"count", o.count},
                              {"succeeded", o.succeeded},
                              {"success_rate", o.count ? double(o.succeeded) / o.count : 0.0}};
  }
  return j.dump(2);
}

}  // namespace ragdoll::actor
