#include "eval/scripted_pushes.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "common/config_section.h"

namespace ragdoll::eval {

bool SideAngle(const std::string& direction, double* angle) {
  static const std::map<std::string, double> kSides = {
      {"forward", 0}, {"left", M_PI / 2}, {"backward", M_PI}, {"right", -M_PI / 2}};
  const auto side = kSides.find(direction);
  if (side == kSides.end()) return false;
  *angle = side->second;
  return true;
}

ScriptedPushes::ScriptedPushes(std::vector<TimedPush> pushes, const character::Character& character)
    : pushes_(std::move(pushes)) {
  for (const TimedPush& p : pushes_) {
    const int body = p.body.empty() ? character.root_body()
                                    : mj_name2id(character.model(), mjOBJ_BODY, p.body.c_str());
    if (body < 1) throw ConfigError("push body '" + p.body + "' is not in the character");
    double side = 0;
    if (!SideAngle(p.direction, &side)) {
      throw ConfigError("push direction '" + p.direction +
                        "': one of forward, backward, left, right");
    }
    bodies_.push_back(body);
    sides_.push_back(side);
  }
}

bool ScriptedPushes::Before(sim::ImitationEnv& env, double t) {
  constexpr double kEps = 1e-9;
  if (active_ >= 0 && t >= pushes_[active_].at + pushes_[active_].duration - kEps) {
    env.SetExternalForce(bodies_[active_], {0, 0, 0});
    active_ = -1;
  }
  if (active_ < 0 && next_ < pushes_.size() && t >= pushes_[next_].at - kEps) {
    const TimedPush& p = pushes_[next_];
    const double angle = sides_[next_] + env.heading();
    const double force = p.impulse / p.duration;
    env.SetExternalForce(bodies_[next_], {force * std::cos(angle), force * std::sin(angle), 0});
    active_ = static_cast<int>(next_++);
    return true;
  }
  return false;
}

std::string ScriptedPushes::Describe(double t, double linger) const {
  for (size_t i = 0; i < next_; ++i) {
    const TimedPush& p = pushes_[i];
    if (t < p.at || t > p.at + p.duration + linger) continue;
    char text[128];
    std::snprintf(text, sizeof text, "push %.0f N s %s", p.impulse, p.direction.c_str());
    return text;
  }
  return "";
}

RandomPushes::RandomPushes(double impulse_min, double impulse_max, double every, double control_dt,
                           uint64_t seed, int body)
    : impulse_min_(impulse_min),
      impulse_max_(impulse_max),
      dt_(control_dt),
      steps_(std::max(1, static_cast<int>(std::lround(0.2 / control_dt)))),
      interval_(every > 0 ? std::max(steps_ + 1, static_cast<int>(std::lround(every / control_dt)))
                          : 0),
      body_(body),
      rng_(seed) {}

bool RandomPushes::Before(sim::ImitationEnv& env, int step) {
  if (started_ >= 0 && step >= started_ + steps_) {
    env.SetExternalForce(body_, {0, 0, 0});
    started_ = -1;
  }
  if (interval_ <= 0 || step == 0 || step % interval_ != 0) return false;
  last_impulse_ = impulse_max_ > impulse_min_
                      ? std::uniform_real_distribution<double>(impulse_min_, impulse_max_)(rng_)
                      : impulse_max_;
  last_angle_ = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng_);
  const double force = last_impulse_ / (steps_ * dt_);
  env.SetExternalForce(body_, {force * std::cos(last_angle_), force * std::sin(last_angle_), 0});
  started_ = step;
  ++count_;
  return true;
}

}  // namespace ragdoll::eval
