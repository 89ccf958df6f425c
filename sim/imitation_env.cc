#include "sim/imitation_env.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "character/ground_contacts.h"
#include "common/config_section.h"
#include "sim/observation.h"
#include "sim/recovery_task.h"
#include "sim/steering_task.h"

namespace ragdoll::sim {
namespace {

constexpr int kImitationTermCount = static_cast<int>(std::size(kImitationTerms));

// A pelvis this much higher or lower than a get-up key frame's counts as much as its trunk
// turned a radian from the frame's, m.
constexpr double kGetUpHeightScale = 0.25;

// Half-width of the central difference that turns reference joint angles into joint velocities.
// Well under a key-frame interval (33 ms at 30 fps), well above rounding.
constexpr double kVelocityStep = 1e-3;

// A command this slow asks the character to stand still (a captured stand drifts by a few
// cm/s).
bool TellsToStandStill(const Command& c) {
  constexpr double kStill = 0.1;  // m/s, and rad/s for the turn
  return std::abs(c.forward) < kStill && std::abs(c.left) < kStill && std::abs(c.turn) < kStill;
}

double Yaw(const double* q) {
  return std::atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
}

character::Vec3 CentreOfMassOf(const character::Character& c, const mjData& d) {
  character::Vec3 com = {0, 0, 0};
  for (int b : c.bodies()) {
    for (int k = 0; k < 3; ++k) com[k] += c.model()->body_mass[b] * d.xipos[3 * b + k];
  }
  for (double& x : com) x /= c.total_mass();
  return com;
}

void RunSubsteps(const mjModel* m, mjData* d, int substeps) {
  // mj_step = mj_step1 (positions, velocities, contacts) + mj_step2 (forces, integration).
  // Running step1 after each integration instead of before keeps every derived quantity in
  // `d` current for the observation and reward at no extra cost (Euler integrator).
  for (int s = 0; s < substeps; ++s) {
    mj_step2(m, d);
    mj_step1(m, d);
  }
}

EnvSpec SpecWithTask(const EnvConfig& config, const character::Character& character,
                     const Task& task) {
  EnvSpec spec;
  spec.observation_size = ObservationSize(character) + task.observation_size();
  spec.observation_names = ObservationNames(character);
  for (std::string& name : task.ObservationNames()) {
    spec.observation_names.push_back(std::move(name));
  }
  spec.action_size = static_cast<int>(character.hinges().size());
  for (const auto& h : character.hinges()) spec.action_names.push_back(h.name);
  spec.control_dt = config.control_dt();
  spec.max_episode_steps = config.max_episode_steps;
  spec.max_reward_per_step = config.reward.MaxReward() + task.max_reward();
  spec.figure_names.assign(std::begin(kImitationTerms), std::end(kImitationTerms));
  if (!task.reward_term().empty()) spec.figure_names.push_back(task.reward_term());
  spec.reward_terms = static_cast<int>(spec.figure_names.size());
  spec.figure_units.assign(spec.figure_names.size(), "");
  std::vector<FigureSpec> figures = task.FigureSpecs();
  if (config.perturbations.enabled()) {
    for (FigureSpec& f : Perturbations::FigureSpecs()) figures.push_back(std::move(f));
  }
  for (const FigureSpec& f : figures) {
    spec.figure_names.push_back(f.name);
    spec.figure_units.push_back(f.unit);
  }
  spec.task = task.name();
  return spec;
}

}  // namespace

std::unique_ptr<Task> MakeTask(const EnvConfig& config) {
  std::unique_ptr<Task> task =
      config.steering.enabled() ? std::make_unique<SteeringTask>(config) : std::make_unique<Task>();
  if (config.recovery.enabled()) return std::make_unique<RecoveryTask>(config, std::move(task));
  return task;
}

EnvSpec MakeEnvSpec(const EnvConfig& config) {
  return MakeEnvSpec(config, *character::Character::Load(config.character, config.physics_dt()));
}

EnvSpec MakeEnvSpec(const EnvConfig& config, const character::Character& character) {
  return SpecWithTask(config, character, *MakeTask(config));
}

const char* EpisodeEndName(EpisodeEnd end) {
  switch (end) {
    case EpisodeEnd::kRunning:
      return "running";
    case EpisodeEnd::kFell:
      return "fell";
    case EpisodeEnd::kStrayed:
      return "strayed";
    case EpisodeEnd::kUnstable:
      return "unstable";
    case EpisodeEnd::kTimeLimit:
      return "time_limit";
    case EpisodeEnd::kClipEnd:
      return "clip_end";
  }
  return "?";
}

ImitationEnv::ImitationEnv(std::shared_ptr<const character::Character> character,
                           std::shared_ptr<const character::MotionClip> clip,
                           const EnvConfig& config, uint64_t seed)
    : ImitationEnv(std::move(character),
                   std::make_shared<const MotionSet>(
                       std::vector<MotionSetEntry>{{clip->name(), clip, MeasureCommand(*clip)}}),
                   config, seed) {
  if (config.steering.enabled()) {
    throw std::invalid_argument("a steering environment is built from its motion set");
  }
}

ImitationEnv::ImitationEnv(std::shared_ptr<const character::Character> character,
                           std::shared_ptr<const MotionSet> motions, const EnvConfig& config,
                           uint64_t seed, std::unique_ptr<Task> task)
    : character_(std::move(character)),
      motions_(std::move(motions)),
      config_(config),
      rng_(seed),
      data_(character_->MakeData()),
      ref_data_(character_->MakeData()),
      task_(task ? std::move(task) : MakeTask(config)) {
  const mjModel* m = character_->model();
  if (std::abs(m->opt.timestep - config_.physics_dt()) > 1e-12) {
    throw std::invalid_argument("character timestep " + std::to_string(m->opt.timestep) +
                                " s differs from the config's physics step " +
                                std::to_string(config_.physics_dt()) + " s");
  }
  task_->Check(*motions_);
  reference_entry_ = task_->StartEntry(*motions_);
  clip_ = motions_->entry(reference_entry_).clip.get();
  const auto& joints = character_->joints();
  for (const auto& [name, w] : config_.joint_weights) {
    bool found =
        std::any_of(joints.begin(), joints.end(),
                    [&name = name](const character::CharacterJoint& j) { return j.name == name; });
    if (!found) throw ConfigError("joint_weights: the character has no joint '" + name + "'");
  }
  for (const auto& j : joints) {
    auto it = config_.joint_weights.find(j.name);
    joint_weights_.push_back(it == config_.joint_weights.end() ? 0.0 : it->second);
  }
  for (const auto& h : character_->hinges()) hinge_joint_.push_back(h.joint);
  may_touch_ground_.assign(m->nbody, 0);
  ResolveAllowedContacts(*motions_, *character_, &config_);
  for (const auto& name : config_.allowed_contacts) {
    int id = mj_name2id(m, mjOBJ_BODY, name.c_str());
    if (id < 0) {
      throw ConfigError("allowed_contacts: the character has no body '" + name + "'");
    }
    may_touch_ground_[id] = 1;
  }

  if (config_.perturbations.enabled()) {
    // A stream of its own (the seed's bits turned), so that pushes leave the start phases be.
    perturbations_ = std::make_unique<Perturbations>(config_.perturbations, *character_,
                                                     config_.control_dt(), ~seed);
  }
  spec_ = SpecWithTask(config_, *character_, *task_);
  imitation_observation_size_ = ObservationSize(*character_);
  episode_.figures.assign(spec_.figure_names.size(), 0.0);

  qpos_before_.resize(m->nq);
  qpos_after_.resize(m->nq);
  qvel_scratch_.resize(m->nv);
}

void ImitationEnv::ReferenceState(double time, double* qpos, double* qvel) const {
  ClipState(time, qpos, qvel);
  if (reference_yaw_ == 0 && reference_offset_[0] == 0 && reference_offset_[1] == 0) return;
  const double c = std::cos(reference_yaw_), s = std::sin(reference_yaw_);
  const double x = qpos[0], y = qpos[1];
  qpos[0] = c * x - s * y + reference_offset_[0];
  qpos[1] = s * x + c * y + reference_offset_[1];
  const character::Quat turned =
      character::Multiply(character::AxisAngle({0, 0, 1}, reference_yaw_),
                          character::Quat{qpos[3], qpos[4], qpos[5], qpos[6]});
  std::copy(turned.begin(), turned.end(), qpos + 3);
  // The free joint's linear velocity is in world axes (turned with the path); its angular
  // velocity is in the root's own axes, which turn with the root.
  const double vx = qvel[0], vy = qvel[1];
  qvel[0] = c * vx - s * vy;
  qvel[1] = s * vx + c * vy;
}

void ImitationEnv::SyncReference(double time) {
  const double* root = data_->qpos;
  std::vector<double> qpos(character_->model()->nq);
  if (motions_->entry(reference_entry_).get_up) {
    // A get-up clip turns to the character however the config syncs: lying, by the body's yaw.
    ReferenceState(time, qpos.data(), qvel_scratch_.data());
    reference_yaw_ +=
        character::WrapAngle(character::BodyYawOf({root[3], root[4], root[5], root[6]}) -
                             character::BodyYawOf({qpos[3], qpos[4], qpos[5], qpos[6]}));
  } else if (const std::optional<double> heading = task_->reference_heading()) {
    ReferenceState(time, qpos.data(), qvel_scratch_.data());
    reference_yaw_ += character::WrapAngle(*heading - Yaw(qpos.data() + 3));
  } else if (config_.reference_sync == ReferenceSync::kPositionAndHeading) {
    ReferenceState(time, qpos.data(), qvel_scratch_.data());
    reference_yaw_ += Yaw(root + 3) - Yaw(qpos.data() + 3);
  }
  // With the yaw fixed, the offset that puts the reference root over the character's.
  ClipState(time, qpos.data(), qvel_scratch_.data());
  const double c = std::cos(reference_yaw_), s = std::sin(reference_yaw_);
  reference_offset_[0] = root[0] - (c * qpos[0] - s * qpos[1]);
  reference_offset_[1] = root[1] - (s * qpos[0] + c * qpos[1]);
}

void ImitationEnv::ClipState(double time, double* qpos, double* qvel) const {
  clip_->SampleInto(time, &pose_scratch_);
  character_->PoseToQpos(pose_scratch_, qpos);
  character::Vec3 linear, angular;
  clip_->SampleRootVelocity(time, &linear, &angular);
  for (int k = 0; k < 3; ++k) {
    qvel[k] = linear[k];
    qvel[3 + k] = angular[k];
  }
  // Hinge velocities: a central difference of the decomposed (and clamped) angles, so that the
  // reference velocity is exactly the rate of change of the reference joint coordinates.
  clip_->SampleInto(time - kVelocityStep, &pose_scratch_);
  character_->PoseToQpos(pose_scratch_, qpos_before_.data());
  clip_->SampleInto(time + kVelocityStep, &pose_scratch_);
  character_->PoseToQpos(pose_scratch_, qpos_after_.data());
  for (const auto& h : character_->hinges()) {
    qvel[h.dof_address] =
        (qpos_after_[h.qpos_address] - qpos_before_[h.qpos_address]) / (2 * kVelocityStep);
  }
}

void ImitationEnv::Reset(float* observation) {
  task_->ChooseEpisode(*this, rng_);
  double phase = config_.start_phase;
  if (config_.random_start) {
    phase = std::uniform_real_distribution<double>(0.0, 1.0)(rng_);
  }
  ResetAtPhase(phase, observation);
}

void ImitationEnv::ResetAtPhase(double phase, float* observation) {
  const mjModel* m = character_->model();
  mjData* d = data_.get();
  mj_resetData(m, d);
  if (perturbations_) perturbations_->Reset();
  reference_entry_ = task_->StartEntry(*motions_);
  clip_ = motions_->entry(reference_entry_).clip.get();
  time_ = phase * clip_->duration();
  reference_yaw_ = 0;
  reference_offset_[0] = reference_offset_[1] = 0;
  ReferenceState(time_, d->qpos, d->qvel);
  mj_forward(m, d);

  episode_ = EpisodeStats();
  episode_.figures.assign(spec_.figure_names.size(), 0.0);
  term_sums_ = RewardTerms();
  episode_.max_length = config_.max_episode_steps;
  task_->Start(*this, rng_);
  if (task_->ends_with_clip() && !clip_->loop()) {
    int remaining =
        static_cast<int>(std::floor((clip_->duration() - time_) / config_.control_dt() + 1e-9));
    episode_.max_length = std::clamp(remaining, 1, config_.max_episode_steps);
  }
  WriteObservation(observation);
}

void ImitationEnv::WriteObservation(float* observation) const {
  BuildObservation(*character_, *data_, clip_->Phase(time_), observation);
  task_->WriteObservation(*this, observation + imitation_observation_size_);
}

double ImitationEnv::heading() const { return Yaw(data_->qpos + 3); }

character::Vec3 ImitationEnv::CentreOfMass() const { return CentreOfMassOf(*character_, *data_); }

void ImitationEnv::SwitchReference(int entry) {
  const character::MotionClip& clip = *motions_->entry(entry).clip;
  // The key frame whose pose is closest to the character's (weighted joint rotation error, as
  // the reward's rotation term); a transition is entered in its first half only, a get-up before
  // its last tenth and by the trunk's posture too (a body lying with straight legs is nearest
  // in its joints to the get-up's last, standing frames).
  const int n = clip.num_frames();
  const bool get_up = motions_->entry(entry).get_up;
  const int last = clip.loop() ? n - 1 : get_up ? std::max(1, n * 9 / 10) : std::max(1, n / 2);
  const character::Quat root_rotation = {data_->qpos[3], data_->qpos[4], data_->qpos[5],
                                         data_->qpos[6]};
  const character::Vec3 up = character::Rotate(root_rotation, {0, 0, 1}),
                        front = character::Rotate(root_rotation, {1, 0, 0});
  double weight_sum = 0;
  for (double w : joint_weights_) weight_sum += w;
  int best = 0;
  double best_error = std::numeric_limits<double>::infinity();
  const auto& joints = character_->joints();
  std::vector<character::Quat> current(joints.size());
  for (size_t j = 0; j < joints.size(); ++j) {
    current[j] = character_->JointRotation(data_->qpos, static_cast<int>(j));
  }
  for (int f = 0; f < last; ++f) {
    const character::Pose& pose = clip.frame(f);
    double error = 0;
    for (size_t j = 0; j < joints.size(); ++j) {
      if (joint_weights_[j] == 0) continue;
      double a = character::AngleBetween(current[j], pose.joint_rotations[j]);
      error += joint_weights_[j] / weight_sum * a * a;
    }
    if (get_up) {
      // How far up the trunk's up and front axes point, and how high the pelvis is, compared.
      const character::Vec3 frame_up = character::Rotate(pose.root_rotation, {0, 0, 1});
      const character::Vec3 frame_front = character::Rotate(pose.root_rotation, {1, 0, 0});
      const double height = (data_->qpos[2] - pose.root_position[2]) / kGetUpHeightScale;
      error += std::pow(up[2] - frame_up[2], 2) + std::pow(front[2] - frame_front[2], 2) +
               height * height;
    }
    if (error < best_error) {
      best_error = error;
      best = f;
    }
  }
  reference_entry_ = entry;
  clip_ = &clip;
  time_ = clip.frame_time(best);
  reference_yaw_ = 0;
  reference_offset_[0] = reference_offset_[1] = 0;
  SyncReference(time_);
  ReferenceState(time_, ref_data_->qpos, ref_data_->qvel);
}

void ImitationEnv::ReferenceAction(float* action) const {
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  ReferenceState(time_ + config_.control_dt(), qpos.data(), qvel.data());
  const auto& hinges = character_->hinges();
  for (size_t i = 0; i < hinges.size(); ++i) {
    if (config_.action_mode == ActionMode::kOffset) {
      action[i] = 0;
    } else {
      const character::ActuatedHinge& h = hinges[i];
      action[i] =
          static_cast<float>(2 * (qpos[h.qpos_address] - h.lower) / (h.upper - h.lower) - 1);
    }
  }
}

void ImitationEnv::SetExternalForce(int body, const character::Vec3& force) {
  double* f = data_->xfrc_applied + 6 * body;
  for (int i = 0; i < 3; ++i) {
    f[i] = force[i];
    f[3 + i] = 0;
  }
}

void ImitationEnv::SetState(const double* qpos, const double* qvel) {
  const mjModel* m = character_->model();
  std::copy(qpos, qpos + m->nq, data_->qpos);
  std::copy(qvel, qvel + m->nv, data_->qvel);
  mj_forward(m, data_.get());
}

void ImitationEnv::Features(const mjData& d, PoseFeatures* f) const {
  const character::Character& c = *character_;
  const auto& joints = c.joints();
  f->joint_rotations.resize(joints.size());
  for (size_t j = 0; j < joints.size(); ++j) {
    f->joint_rotations[j] = c.JointRotation(d.qpos, static_cast<int>(j));
  }
  const auto& hinges = c.hinges();
  f->joint_velocities.resize(hinges.size());
  for (size_t i = 0; i < hinges.size(); ++i) f->joint_velocities[i] = d.qvel[hinges[i].dof_address];
  const double* root = d.xpos + 3 * c.root_body();
  f->end_effectors.resize(c.end_effectors().size());
  for (size_t e = 0; e < c.end_effectors().size(); ++e) {
    const double* p = d.xpos + 3 * c.end_effectors()[e];
    f->end_effectors[e] = {p[0] - root[0], p[1] - root[1], p[2] - root[2]};
  }
  f->com = CentreOfMassOf(c, d);
  f->root_position = {d.qpos[0], d.qpos[1], d.qpos[2]};
  f->root_rotation = {d.qpos[3], d.qpos[4], d.qpos[5], d.qpos[6]};
  f->root_linear_velocity = {d.qvel[0], d.qvel[1], d.qvel[2]};
  f->root_angular_velocity = {d.qvel[3], d.qvel[4], d.qvel[5]};
}

RewardTerms ImitationEnv::Score() {
  mj_kinematics(character_->model(), ref_data_.get());
  Features(*data_, &sim_features_);
  Features(*ref_data_, &ref_features_);
  RewardErrors errors =
      ImitationErrors(config_.reward, joint_weights_, hinge_joint_, sim_features_, ref_features_);
  return ImitationReward(config_.reward, errors);
}

RewardTerms ImitationEnv::RewardAt(double time) {
  ReferenceState(time, ref_data_->qpos, ref_data_->qvel);
  return Score();
}

bool ImitationEnv::Diverged() const {
  const mjModel* m = character_->model();
  const mjData* d = data_.get();
  // MuJoCo resets the state itself on a bad acceleration and records a warning.
  if (d->warning[mjWARN_BADQACC].number > 0 || d->warning[mjWARN_BADQPOS].number > 0 ||
      d->warning[mjWARN_BADQVEL].number > 0) {
    return true;
  }
  for (int i = 0; i < m->nq; ++i) {
    if (!std::isfinite(d->qpos[i])) return true;
  }
  for (int i = 0; i < m->nv; ++i) {
    if (!std::isfinite(d->qvel[i])) return true;
  }
  return false;
}

EpisodeEnd ImitationEnv::CheckTermination() const {
  if (!task_->falls_end_episode())
    return task_->failed() ? EpisodeEnd::kFell : EpisodeEnd::kRunning;
  const mjModel* m = character_->model();
  const mjData* d = data_.get();
  if (character::TouchesGroundOutside(m, *d, may_touch_ground_)) return EpisodeEnd::kFell;
  double distance2 = 0;
  for (int k = 0; k < 3; ++k) {
    double e = d->qpos[k] - ref_data_->qpos[k];
    distance2 += e * e;
  }
  if (distance2 > config_.max_root_distance * config_.max_root_distance) {
    return EpisodeEnd::kStrayed;
  }
  return EpisodeEnd::kRunning;
}

void ImitationEnv::SetJointTargets(const float* action) {
  mjData* d = data_.get();
  mjData* ref = ref_data_.get();
  const auto& hinges = character_->hinges();
  for (size_t i = 0; i < hinges.size(); ++i) {
    const character::ActuatedHinge& h = hinges[i];
    double a = action[i];
    if (!std::isfinite(a)) {
      ++bad_actions_;
      a = 0;
    }
    a = std::clamp(a, -1.0, 1.0);
    double target;
    if (config_.action_mode == ActionMode::kOffset) {
      target = ref->qpos[h.qpos_address] + a * config_.offset_scale * 0.5 * (h.upper - h.lower);
    } else {
      target = h.lower + 0.5 * (a + 1) * (h.upper - h.lower);
    }
    d->ctrl[h.actuator] = std::clamp(target, h.lower, h.upper);
  }
}

void ImitationEnv::ApplyPushes() {
  if (perturbations_) {
    const MotionSetEntry& entry = motions_->entry(reference_entry_);
    perturbations_->BeforeStep(data_.get(), !entry.get_up,
                               {heading(), TellsToStandStill(entry.command)});
  }
}

void ImitationEnv::AdvanceReference(double next_time) {
  mjData* ref = ref_data_.get();
  const double previous = time_;
  time_ = next_time;
  // Unless the task placed the reference itself, a new cycle of a looping clip moves it onto the
  // character (DeepMimic), so drift from earlier cycles is not scored again. The hinge targets
  // (SetJointTargets) do not depend on it.
  if (!task_->Advance(*this, rng_) &&
      (task_->reference_heading() || config_.reference_sync != ReferenceSync::kNone) &&
      clip_->loop() &&
      std::floor(time_ / clip_->duration()) > std::floor(previous / clip_->duration())) {
    SyncReference(time_);
    ReferenceState(time_, ref->qpos, ref->qvel);
  }
}

StepResult ImitationEnv::ScoreStep() {
  const mjModel* m = character_->model();
  mjData* d = data_.get();
  mjData* ref = ref_data_.get();
  StepResult result;
  if (Diverged()) {
    ++unstable_resets_;
    episode_.end = EpisodeEnd::kUnstable;
    result.terminated = true;
    // Leave a finite observation: the reference pose.
    mj_resetData(m, d);
    std::copy(ref->qpos, ref->qpos + m->nq, d->qpos);
    std::copy(ref->qvel, ref->qvel + m->nv, d->qvel);
    mj_forward(m, d);
  } else {
    result.terms = Score();
    const double imitation = result.terms.total;
    result.terms.task = task_->Reward(*this, sim_features_);
    result.terms.total += result.terms.task;
    result.reward = task_->imitation_scale() * imitation + result.terms.task;
    EpisodeEnd end = CheckTermination();
    if (end != EpisodeEnd::kRunning) {
      episode_.end = end;
      result.terminated = true;
    } else if (episode_.length >= episode_.max_length) {
      episode_.end = clip_->loop() || episode_.max_length == config_.max_episode_steps
                         ? EpisodeEnd::kTimeLimit
                         : EpisodeEnd::kClipEnd;
      result.truncated = true;
    }
  }
  return result;
}

void ImitationEnv::UpdateEpisode(const StepResult& result, int falls_before) {
  episode_.task_falls = task_->falls();
  episode_.episode_return += result.reward;
  term_sums_.rotation += result.terms.rotation;
  term_sums_.velocity += result.terms.velocity;
  term_sums_.end_effector += result.terms.end_effector;
  term_sums_.com += result.terms.com;
  term_sums_.root += result.terms.root;
  term_sums_.task += result.terms.task;
  term_sums_.total += result.terms.total;
  double n = episode_.length;
  episode_.mean_terms = {term_sums_.rotation / n,     term_sums_.velocity / n,
                         term_sums_.end_effector / n, term_sums_.com / n,
                         term_sums_.root / n,         term_sums_.task / n,
                         term_sums_.total / n};
  const RewardTerms& mean = episode_.mean_terms;
  double* figures = episode_.figures.data();
  for (double term : {mean.rotation, mean.velocity, mean.end_effector, mean.com, mean.root}) {
    *figures++ = term;
  }
  if (spec_.reward_terms > kImitationTermCount) *figures++ = mean.task;
  task_->Figures(n, figures);
  if (perturbations_) {
    perturbations_->AfterStep(episode_.ended_in_fall() || task_->falls() > falls_before);
    episode_.figures.back() = perturbations_->level();
  }
  episode_.normalized_return =
      episode_.episode_return / (spec_.max_reward_per_step * episode_.max_length);
}

StepResult ImitationEnv::Step(const float* action, float* observation) {
  const double next_time = time_ + config_.control_dt();
  ReferenceState(next_time, ref_data_->qpos, ref_data_->qvel);
  const int falls_before = task_->falls();
  SetJointTargets(action);
  ApplyPushes();
  RunSubsteps(character_->model(), data_.get(), config_.substeps);
  AdvanceReference(next_time);
  ++episode_.length;
  StepResult result = ScoreStep();
  UpdateEpisode(result, falls_before);
  WriteObservation(observation);
  return result;
}

}  // namespace ragdoll::sim
