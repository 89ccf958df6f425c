#include "sim/perturbations.h"

#include <algorithm>
#include <cmath>

#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

int Steps(double seconds, double control_dt) {
  return std::max(1, static_cast<int>(std::lround(seconds / control_dt)));
}

// The share of falls remembered: about the last ten judged pushes of a situation.
constexpr double kFallShareRate = 0.1;
// A quarter whose pushes are all survived is still drawn this much (against its fall share).
constexpr double kQuarterFloor = 0.05;

}  // namespace

Perturbations::Perturbations(const PerturbationConfig& config,
                             const character::Character& character, double control_dt,
                             uint64_t seed)
    : config_(config), control_dt_(control_dt), rng_(seed) {
  for (const auto& name : config.bodies) {
    const int id = mj_name2id(character.model(), mjOBJ_BODY, name.c_str());
    if (id < 1) throw ConfigError("perturbations: the character has no body '" + name + "'");
    bodies_.push_back(id);
  }
  const size_t situations = config.per_situation ? bodies_.size() * kQuarters * 2 : 1;
  curricula_.assign(situations, Curriculum{config.start});
  Reset();
}

int Perturbations::Index(int body, int quarter, bool still) const {
  if (!config_.per_situation) return 0;
  return (body * kQuarters + quarter) * 2 + (still ? 1 : 0);
}

double Perturbations::level() const {
  double sum = 0;
  for (const Curriculum& c : curricula_) sum += c.level;
  return sum / curricula_.size();
}

double Perturbations::level(int body, Quarter quarter, bool still) const {
  return curricula_[Index(body, quarter, still)].level;
}

double Perturbations::fall_share(int body, Quarter quarter, bool still) const {
  return curricula_[Index(body, quarter, still)].fall_share;
}

double Perturbations::DrawAngle(int body, const PushSituation& situation, int* curriculum) {
  std::uniform_real_distribution<double> unit(0, 1);
  if (!config_.per_situation) {
    *curriculum = 0;
    return 2 * M_PI * unit(rng_);
  }
  double weights[kQuarters], total = 0;
  for (int q = 0; q < kQuarters; ++q) {
    weights[q] = curricula_[Index(body, q, situation.still)].fall_share + kQuarterFloor;
    total += weights[q];
  }
  double pick = total * unit(rng_);
  int quarter = 0;
  while (quarter < kQuarters - 1 && pick >= weights[quarter]) pick -= weights[quarter++];
  *curriculum = Index(body, quarter, situation.still);
  return situation.heading + M_PI / 2 * (quarter + unit(rng_) - 0.5);
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

void Perturbations::BeforeStep(mjData* d, bool may_push, const PushSituation& situation) {
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
  const int body =
      static_cast<int>(std::uniform_int_distribution<size_t>(0, bodies_.size() - 1)(rng_));
  pushed_body_ = bodies_[body];
  const double duration =
      config_.duration_min + (config_.duration_max - config_.duration_min) * unit(rng_);
  push_steps_left_ = Steps(duration, control_dt_);
  const double impulse_share = 0.5 + 0.5 * unit(rng_);
  const double angle = DrawAngle(body, situation, &judged_curriculum_);
  const double impulse = curricula_[judged_curriculum_].level * impulse_share;
  const double force = impulse / (push_steps_left_ * control_dt_);
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
  Curriculum& c = curricula_[judged_curriculum_];
  c.fall_share += kFallShareRate * ((survived ? 0.0 : 1.0) - c.fall_share);
  ++c.judged;
  c.survived += survived ? 1 : 0;
  if (c.judged < config_.window) return;
  const double rate = static_cast<double>(c.survived) / c.judged;
  if (rate >= config_.raise_above) c.level = std::min(config_.max, c.level + config_.step);
  if (rate < config_.lower_below) c.level = std::max(config_.start, c.level - config_.step);
  c.judged = c.survived = 0;
}

}  // namespace ragdoll::sim
