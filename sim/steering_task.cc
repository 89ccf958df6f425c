#include "sim/steering_task.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "sim/imitation_env.h"
#include "sim/recovery_task.h"

namespace ragdoll::sim {

SteeringTask::SteeringTask(const EnvConfig& config)
    : config_(config.steering),
      control_dt_(config.control_dt()),
      stand_after_get_up_(config.recovery.stand_after_get_up) {
  if (!config_.enabled()) throw std::invalid_argument("a steering task needs steering.motions");
  // The set's first command, as MotionSet::commands() orders them.
  const auto& items = config_.motions;
  command_entry_ =
      static_cast<int>(std::find_if(items.begin(), items.end(),
                                    [](const MotionSetItem& item) { return !item.transition(); }) -
                       items.begin());
  const int window =
      std::max(1, static_cast<int>(std::lround(config_.velocity_window / control_dt_)));
  com_history_.resize(window + 1);
}

int SteeringTask::observation_size() const { return 5 + static_cast<int>(config_.motions.size()); }

std::vector<std::string> SteeringTask::ObservationNames() const {
  std::vector<std::string> names = {"command.forward", "command.left", "command.turn",
                                    "command.heading_error.sin", "command.heading_error.cos"};
  for (const MotionSetItem& item : config_.motions) names.push_back("reference." + item.name);
  return names;
}

void SteeringTask::Check(const MotionSet& set) const {
  const auto get_up = std::count_if(set.entries().begin(), set.entries().end(),
                                    [](const MotionSetEntry& e) { return e.get_up; });
  if (set.size() - get_up != static_cast<int>(config_.motions.size())) {
    throw std::invalid_argument("the motion set does not match the config's steering.motions");
  }
}

void SteeringTask::WriteObservation(const TaskHost& env, float* out) const {
  const double error = character::WrapAngle(desired_heading_ - env.heading());
  const double c = std::cos(error), s = std::sin(error);
  const Command& asked = Asked();
  *out++ = static_cast<float>(c * asked.forward - s * asked.left);
  *out++ = static_cast<float>(s * asked.forward + c * asked.left);
  *out++ = static_cast<float>(asked.turn);
  *out++ = static_cast<float>(s);
  *out++ = static_cast<float>(c);
  // The get-up clips (EnvConfig::recovery) follow the steering clips and are not among these.
  const int entries = static_cast<int>(config_.motions.size());
  for (int i = 0; i < entries; ++i) *out++ = i == env.reference_entry() ? 1.0f : 0.0f;
}

int SteeringTask::RandomCommand(const MotionSet& set, std::mt19937_64& rng) const {
  const std::vector<int>& commands = set.commands();
  std::vector<double> weights;
  for (int entry : commands) weights.push_back(config_.motions[entry].weight);
  // Equal weights draw as they always have, so that recorded seeds replay the same commands.
  if (std::all_of(weights.begin(), weights.end(), [&](double w) { return w == weights[0]; })) {
    return commands[std::uniform_int_distribution<size_t>(0, commands.size() - 1)(rng)];
  }
  return commands[std::discrete_distribution<size_t>(weights.begin(), weights.end())(rng)];
}

void SteeringTask::ChooseEpisode(const TaskHost& env, std::mt19937_64& rng) {
  if (random_commands_) command_entry_ = RandomCommand(env.motion_set(), rng);
}

void SteeringTask::Start(TaskHost& env, std::mt19937_64& rng) {
  const MotionSet& set = env.motion_set();
  command_ = set.entry(command_entry_).command;
  stand_entry_ = set.Nearest(Command{});
  standing_ = set.entry(stand_entry_).command;
  catching_ = -1;
  error_sums_[0] = error_sums_[1] = 0;
  episode_time_ = 0;
  stand_until_ = -1;
  resume_pending_ = false;
  FaceAndTravelAsNow(env);
  next_command_time_ = std::uniform_real_distribution<double>(config_.command_interval_min,
                                                              config_.command_interval_max)(rng);
}

void SteeringTask::Resume(TaskHost& env) {
  // The heading held before the fall may be anywhere after a get-up; a player steers on from
  // where the character stands, and the history stopped while it was down.
  FaceAndTravelAsNow(env);
  catching_ = -1;
  if (stand_after_get_up_ > 0 && command_entry_ != stand_entry_) {
    stand_until_ = episode_time_ + stand_after_get_up_;
    resume_pending_ = true;
  }
}

int SteeringTask::ResumeEntry(const MotionSet& set) const {
  if (standing_after_get_up()) return stand_entry_;
  const int transition = set.Transition(stand_entry_, command_entry_);
  return transition >= 0 ? transition : command_entry_;
}

void SteeringTask::Lead(TaskHost& env) {
  const MotionSet& set = env.motion_set();
  const int now = env.reference_entry();
  const int asked = standing_after_get_up() ? stand_entry_ : command_entry_;
  if (now == asked) return;
  // A transition leads away only from its `from` clip itself, not from another transition.
  const int transition = set.entry(now).transition() ? -1 : set.Transition(now, asked);
  env.SwitchReference(transition >= 0 ? transition : asked);
}

bool SteeringTask::CatchStep(TaskHost& env) {
  if (config_.catch_above <= 0) return false;
  if (catching_ >= 0) {
    if (episode_time_ < catch_until_ - 1e-9) return false;
    catching_ = -1;
    if (!standing_after_get_up()) resume_pending_ = false;  // Lead does what it would
    Lead(env);  // back to the stand, or to a command given meanwhile
    return true;
  }
  if (env.reference_entry() != stand_entry_ ||
      (command_entry_ != stand_entry_ && !standing_after_get_up())) {
    return false;
  }
  const double vx = env.data().qvel[0], vy = env.data().qvel[1];
  if (std::hypot(vx, vy) <= config_.catch_above) return false;
  // The pelvis's velocity seen from the desired heading, as commands are given.
  const double c = std::cos(desired_heading_), s = std::sin(desired_heading_);
  const int entry = env.motion_set().Nearest({c * vx + s * vy, -s * vx + c * vy, 0});
  if (entry == stand_entry_) return false;
  catching_ = entry;
  catch_until_ = episode_time_ + config_.catch_seconds;
  env.SwitchReference(entry);
  return true;
}

void SteeringTask::FaceAndTravelAsNow(const TaskHost& env) {
  desired_heading_ = env.heading();
  // The travel history as if the character had moved at its current root velocity for the
  // whole window.
  const character::Vec3 com = env.CentreOfMass();
  const double* qvel = env.data().qvel;
  const int n = static_cast<int>(com_history_.size());
  for (int i = 0; i < n; ++i) {
    double back = (n - 1 - i) * control_dt_;
    com_history_[i] = {com[0] - back * qvel[0], com[1] - back * qvel[1], com[2]};
  }
  com_head_ = n - 1;  // the newest
}

character::Vec3 SteeringTask::TravelVelocity() const {
  const int n = static_cast<int>(com_history_.size());
  const character::Vec3& newest = com_history_[com_head_];
  const character::Vec3& oldest = com_history_[(com_head_ + 1) % n];
  const double span = (n - 1) * control_dt_;
  return {(newest[0] - oldest[0]) / span, (newest[1] - oldest[1]) / span, 0};
}

double SteeringTask::SpeedError() const { return SpeedErrorFrom(command_); }

double SteeringTask::SpeedErrorFrom(const Command& command) const {
  const character::Vec3 v = TravelVelocity();
  const double c = std::cos(desired_heading_), s = std::sin(desired_heading_);
  return std::hypot(v[0] - (c * command.forward - s * command.left),
                    v[1] - (s * command.forward + c * command.left));
}

double SteeringTask::HeadingError(const TaskHost& env) const {
  return character::WrapAngle(env.heading() - desired_heading_);
}

double SteeringTask::Reward(const TaskHost& env, const PoseFeatures& character) {
  // The centre of mass the imitation terms were just scored with joins the travel history.
  com_head_ = (com_head_ + 1) % static_cast<int>(com_history_.size());
  com_history_[com_head_] = character.com;
  const double v = SpeedErrorFrom(Asked()), h = HeadingError(env);
  const double reward = config_.velocity_weight * std::exp(-config_.velocity_scale * v * v) +
                        config_.heading_weight * std::exp(-config_.heading_scale * h * h);
  error_sums_[0] += SpeedError();
  error_sums_[1] += std::abs(HeadingError(env));
  return reward;
}

void SteeringTask::Figures(double steps, double* out) const {
  out[0] = error_sums_[0] / steps;
  out[1] = error_sums_[1] / steps;
}

void SteeringTask::SetCommand(TaskHost& env, int entry) {
  const MotionSet& set = env.motion_set();
  if (entry < 0 || entry >= set.size() || set.entry(entry).transition()) {
    throw std::invalid_argument("SetCommand: " + std::to_string(entry) +
                                " is not a command of the motion set");
  }
  random_commands_ = false;
  ChangeCommand(env, entry);
}

bool SteeringTask::ChangeCommand(TaskHost& env, int entry) {
  if (entry == command_entry_) return false;
  const MotionSet& set = env.motion_set();
  command_entry_ = entry;
  command_ = set.entry(entry).command;
  // While a get-up plays (RecoveryTask), the character stands after one or takes a catch step,
  // the command waits.
  if (set.entry(env.reference_entry()).get_up || standing_after_get_up() || catching_ >= 0) {
    return true;
  }
  Lead(env);
  return true;
}

bool SteeringTask::Advance(TaskHost& env, std::mt19937_64& rng) {
  episode_time_ += control_dt_;
  desired_heading_ = character::WrapAngle(desired_heading_ + Asked().turn * control_dt_);
  if (resume_pending_ && !standing_after_get_up() && catching_ < 0) {
    resume_pending_ = false;  // the stand after a get-up is over: the command leads
    Lead(env);
    return true;
  }
  const MotionSetEntry& reference = env.motion_set().entry(env.reference_entry());
  if (reference.transition() && env.time() >= env.clip().duration() - 1e-9) {
    env.SwitchReference(reference.to);  // the transition has played: on to its clip
    return true;
  }
  if (random_commands_ && episode_time_ >= next_command_time_) {
    next_command_time_ += std::uniform_real_distribution<double>(config_.command_interval_min,
                                                                 config_.command_interval_max)(rng);
    ChangeCommand(env, RandomCommand(env.motion_set(), rng));
    return true;
  }
  return CatchStep(env);
}

namespace {

// The steering task itself, or the one a recovery task is on top of.
Task& Unwrapped(Task& task) {
  auto* recovery = dynamic_cast<RecoveryTask*>(&task);
  return recovery != nullptr ? recovery->inner() : task;
}

const Task& Unwrapped(const Task& task) {
  const auto* recovery = dynamic_cast<const RecoveryTask*>(&task);
  return recovery != nullptr ? recovery->inner() : task;
}

}  // namespace

SteeringTask& Steering(ImitationEnv& env) {
  auto* steering = dynamic_cast<SteeringTask*>(&Unwrapped(env.task()));
  if (steering == nullptr) throw std::logic_error("the environment has no steering task");
  return *steering;
}

const SteeringTask& Steering(const ImitationEnv& env) {
  auto* steering = dynamic_cast<const SteeringTask*>(&Unwrapped(env.task()));
  if (steering == nullptr) throw std::logic_error("the environment has no steering task");
  return *steering;
}

}  // namespace ragdoll::sim
