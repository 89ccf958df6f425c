#include "eval/command_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "actor/rollout.h"
#include "common/config_section.h"
#include "sim/steering_task.h"

namespace ragdoll::eval {
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
                                const character::Character& character) {
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

namespace {

// The environment of the runs: episodes as long as the longest script, from random phases.
sim::EnvConfig CommandRunEnv(const sim::EnvConfig& env_config, const CommandEvalConfig& config) {
  sim::EnvConfig env = env_config;
  const double dt = env.control_dt();
  const double longest = config.random ? config.duration : config.script.duration;
  env.max_episode_steps = static_cast<int>(std::ceil(longest / dt)) + 1;
  env.random_start = true;
  // A push that only carries the character away from its reference is not a fall.
  if (config.push_interval > 0) env.max_root_distance = std::numeric_limits<double>::infinity();
  return env;
}

// What every run shares: the settings and the one environment the policy steers.
struct RunContext {
  const CommandEvalConfig& config;
  actor::RolloutWorker& worker;
  sim::ImitationEnv& e;
  const sim::SteeringTask& steering;
  const sim::MotionSet& motions;
  double dt;
  double imitation_max;
  bool recovery;  // the policy gets up (EnvConfig::recovery)
};

// What the runs add up: the result, and the sums of the settled steps.
struct Tally {
  CommandEvalResult result;
  std::map<std::string, Sums> per_command;
  Sums overall, moving;
};

// One run of a script from a random phase: its command changes and pushes, the transition it
// scores, its knock-downs.
class CommandRun {
 public:
  CommandRun(const RunContext& context, const CommandScript& script, uint64_t seed, Tally* tally);
  // Plays the script until it ends or a fall ends the episode.
  void Play();
  // Closes the transition still pending and counts the run's knock-downs.
  void Finish();

 private:
  void ChangeCommand(double t);
  void Push(double t, int step);
  // Scores a step that did not end the run: the pending transition, the command's tracking.
  void Score(double t, const sim::StepResult& r);
  void CloseTransition(bool fell);

  const RunContext& c_;
  const CommandScript& script_;
  Tally& tally_;
  ScriptedPushes scripted_;
  RandomPushes random_pushes_;
  KnockDownClock knockdowns_;
  size_t next_ = 1;
  double changed_at_ = 0;
  std::string previous_;  // the command before the last change
  // The pending transition's scoring: from settle until the window ends or the next change.
  Sums transition_;
  bool pending_ = false;
  bool fell_ = false, knocked_ = false;
  double run_time_ = 0;
};

CommandRun::CommandRun(const RunContext& context, const CommandScript& script, uint64_t seed,
                       Tally* tally)
    : c_(context),
      script_(script),
      tally_(*tally),
      scripted_(script.pushes, context.e.character()),
      random_pushes_(0, context.config.push_max, context.config.push_interval, context.dt, seed,
                     context.e.character().root_body()),
      knockdowns_(context.config.transition_speed, context.config.transition_heading,
                  context.config.back_hold) {}

void CommandRun::Play() {
  const double dt = c_.dt;
  sim::ImitationEnv& e = c_.e;
  const int steps = static_cast<int>(std::lround(script_.duration / dt));
  for (int step = 0; step < steps && !fell_; ++step) {
    const double t = step * dt;
    run_time_ = t + dt;
    if (next_ < script_.changes.size() && t >= script_.changes[next_].at - 1e-9) {
      ChangeCommand(t);
    }
    Push(t, step);
    const int falls_before = e.episode().task_falls;
    sim::StepResult r = c_.worker.StepFirst(/*deterministic=*/true);
    tally_.result.seconds += dt;
    if (!r.terminated) {
      knockdowns_.Step(t + dt, e.episode().task_falls > falls_before,
                       c_.motions.entry(e.reference_entry()).get_up, c_.steering.SpeedError(),
                       std::abs(c_.steering.HeadingError(e)));
    }
    knocked_ = knocked_ || r.terminated || e.episode().fell();
    if (r.terminated) {
      fell_ = true;
      ++tally_.result.falls;
      CloseTransition(true);
      break;
    }
    Score(t, r);
  }
}

void CommandRun::ChangeCommand(double t) {
  CloseTransition(false);
  previous_ = c_.motions.entry(c_.steering.command_entry()).name;
  c_.worker.SetCommandFirst(c_.motions.Find(script_.changes[next_].command));
  changed_at_ = t;
  pending_ = true;
  transition_ = Sums();
  ++next_;
}

void CommandRun::Push(double t, int step) {
  if (scripted_.Before(c_.e, t)) {
    ++tally_.result.pushes;
    knockdowns_.Pushed(t);
  }
  if (random_pushes_.Before(c_.e, step)) {
    ++tally_.result.pushes;
    knockdowns_.Pushed(t);
  }
}

void CommandRun::Score(double t, const sim::StepResult& r) {
  const sim::MotionSet& motions = c_.motions;
  const sim::SteeringTask& steering = c_.steering;
  sim::ImitationEnv& e = c_.e;
  // Getting up (EnvConfig::recovery) is scored by --recovery, not as steering.
  if (motions.entry(e.reference_entry()).get_up) return;
  const double since = t + c_.dt - changed_at_;
  if (since < c_.config.settle) return;
  const double speed = steering.SpeedError(), heading = std::abs(steering.HeadingError(e));
  if (pending_) {
    if (since <= c_.config.transition_window) {
      transition_.Add(speed, heading, 0);
    } else {
      CloseTransition(false);
    }
  }
  if (motions.entry(e.reference_entry()).transition()) return;
  const double imitation = (r.terms.total - r.terms.task) / c_.imitation_max;
  const sim::Command& c = steering.command();
  tally_.per_command[motions.entry(steering.command_entry()).name].Add(speed, heading, imitation);
  tally_.overall.Add(speed, heading, imitation);
  if (std::hypot(c.forward, c.left) > 0.1 || std::abs(c.turn) > 0.1) {
    tally_.moving.Add(speed, heading, imitation);
  }
}

void CommandRun::CloseTransition(bool fell) {
  if (!pending_) return;
  pending_ = false;
  if (!fell && transition_.steps == 0) return;  // the next change came before it settled
  TransitionOutcome& o =
      tally_.result.transitions[previous_ + "->" +
                                c_.e.motion_set().entry(c_.steering.command_entry()).name];
  ++o.count;
  if (!fell && transition_.speed / transition_.steps <= c_.config.transition_speed &&
      transition_.heading / transition_.steps <= c_.config.transition_heading) {
    ++o.succeeded;
  }
}

void CommandRun::Finish() {
  if (!fell_) CloseTransition(false);
  if (knocked_) ++tally_.result.knocked_down;
  // Without recovery every fall ends the run: the fall rate says it all.
  if (c_.recovery) {
    knockdowns_.End(run_time_, c_.config.back_window, fell_);
    tally_.result.knockdown_seconds.insert(tally_.result.knockdown_seconds.end(),
                                           knockdowns_.seconds().begin(),
                                           knockdowns_.seconds().end());
  }
}

}  // namespace

CommandEvalResult EvaluateCommands(const sim::EnvConfig& env_config,
                                   const v1::PolicySnapshot& snapshot,
                                   const CommandEvalConfig& config, uint64_t seed) {
  if (!env_config.steering.enabled()) {
    throw std::invalid_argument("--commands needs a run trained with a steering task");
  }
  const sim::EnvConfig env = CommandRunEnv(env_config, config);
  const double dt = env.control_dt();
  actor::RolloutWorker worker(env, 1, 1, seed, "commands");
  worker.SetPolicy(snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  const sim::SteeringTask& steering = sim::Steering(e);
  const sim::MotionSet& motions = e.motion_set();
  const double imitation_max = env.reward.MaxReward();
  const bool recovery = env.recovery.enabled();
  const RunContext context{config, worker, e, steering, motions, dt, imitation_max, recovery};
  std::mt19937_64 phases(seed);

  Tally tally;
  tally.result.back_window = config.back_window;
  for (int run = 0; run < config.runs; ++run) {
    const CommandScript script =
        config.random
            ? RandomCommandScript(motions, config.duration, env.steering.command_interval_min,
                                  env.steering.command_interval_max, seed + 1 + run)
            : config.script;
    worker.SetCommandFirst(motions.Find(script.changes.front().command));
    worker.ResetFirst(std::uniform_real_distribution<double>(0, 1)(phases));
    CommandRun command_run(context, script, seed + 1 + run, &tally);
    ++tally.result.runs;
    command_run.Play();
    command_run.Finish();
  }
  tally.overall.AddTo(&tally.result.overall, dt);
  tally.moving.AddTo(&tally.result.moving, dt);
  for (const auto& [name, sums] : tally.per_command) {
    sums.AddTo(&tally.result.per_command[name], dt);
  }
  return std::move(tally.result);
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

}  // namespace ragdoll::eval
