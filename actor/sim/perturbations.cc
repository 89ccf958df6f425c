#include "actor/sim/perturbations.h"

#include <algorithm>
#include <cmath>

#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

int Steps(double seconds, double control_dt) {
  return std::max(1, static_cast<int>(std::lround(seconds / control_dt)));
}

}  // namespace

Perturbations::Perturbations(const PerturbationConfig& config, const Character& character,
                             double control_dt, uint64_t seed)
    : config_(config), control_dt_(control_dt), rng_(seed), level_(config.start) {
  for (const auto& name : config.bodies) {
    const int id = mj_name2id(character.model(), mjOBJ_BODY, name.c_str());
    if (id < 1) throw ConfigError("perturbations: the character has no body '" + name + "'");
    bodies_.push_back(id);
  }
  Reset();
}

void Perturbations::Reset() {
  const double interval =
      std::uniform_real_distribution<double>(config_.interval_min, config_.interval_max)(rng_);
  steps_to_next_ = Steps(interval, control_dt_);
  push_steps_left_ = 0;
  pushed_body_ = -1;
  // A push whose episode ended before its judgement (a time limit) was survived; a fall has
  // been judged already.
  if (judge_steps_left_ > 0) Judge(true);
}

void Perturbations::BeforeStep(mjData* d, bool may_push) {
  if (push_steps_left_ > 0 && --push_steps_left_ == 0) {
    mju_zero(d->xfrc_applied + 6 * pushed_body_, 3);
  }
  if (--steps_to_next_ > 0) return;
  if (!may_push) {
    steps_to_next_ = 1;
    return;
  }
  if (pushed_body_ >= 0) mju_zero(d->xfrc_applied + 6 * pushed_body_, 3);
  if (judge_steps_left_ > 0) Judge(true);  // pushed again before the last one was judged
  std::uniform_real_distribution<double> unit(0, 1);
  pushed_body_ = bodies_[std::uniform_int_distribution<size_t>(0, bodies_.size() - 1)(rng_)];
  const double duration =
      config_.duration_min + (config_.duration_max - config_.duration_min) * unit(rng_);
  push_steps_left_ = Steps(duration, control_dt_);
  const double impulse = level_ * (0.5 + 0.5 * unit(rng_));
  const double force = impulse / (push_steps_left_ * control_dt_);
  const double angle = 2 * M_PI * unit(rng_);
  double* f = d->xfrc_applied + 6 * pushed_body_;
  f[0] = force * std::cos(angle);
  f[1] = force * std::sin(angle);
  f[2] = 0;
  judge_steps_left_ = Steps(config_.judge, control_dt_);
  ++pushes_;
  steps_to_next_ = push_steps_left_ + Steps(std::uniform_real_distribution<double>(
                                                config_.interval_min, config_.interval_max)(rng_),
                                            control_dt_);
}

void Perturbations::AfterStep(bool fell) {
  if (judge_steps_left_ == 0) return;
  if (fell) {
    Judge(false);
  } else if (--judge_steps_left_ == 0) {
    Judge(true);
  }
}

void Perturbations::Judge(bool survived) {
  judge_steps_left_ = 0;
  ++judged_;
  survived_ += survived ? 1 : 0;
  if (judged_ < config_.window) return;
  const double rate = static_cast<double>(survived_) / judged_;
  if (rate >= config_.raise_above) level_ = std::min(config_.max, level_ + config_.step);
  if (rate < config_.lower_below) level_ = std::max(config_.start, level_ - config_.step);
  judged_ = survived_ = 0;
}

}  // namespace ragdoll::sim
