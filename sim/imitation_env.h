// The imitation environment: a MuJoCo ragdoll rewarded for following a reference clip
// (DeepMimic). Three methods, as in EnvPool: Reset, Step, spec().
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"
#include "sim/env_config.h"
#include "sim/imitation_reward.h"
#include "sim/motion_set.h"
#include "sim/perturbations.h"
#include "sim/task.h"

namespace ragdoll::sim {

struct EnvSpec {
  int observation_size = 0;
  int action_size = 0;
  std::vector<std::string> observation_names;
  std::vector<std::string> action_names;  // one per actuated hinge
  double control_dt = 0;
  int max_episode_steps = 0;
  double max_reward_per_step = 0;
  // The figures reported for each finished episode (EpisodeStats::figures, per-step means), by
  // the names the learner's log, the metrics, the evaluation and the report show: the reward
  // terms first (the imitation terms, then the task's), then the task's own figures.
  std::vector<std::string> figure_names;
  std::vector<std::string> figure_units;  // of each figure: "" for a reward term, "m/s", "rad"
  int reward_terms = 0;                   // how many of the figures are reward terms
  std::string task;                       // the task's name ("steering"); empty: imitation alone
};

// The spec of the environment `config` describes, for `character`, without building it.
EnvSpec MakeEnvSpec(const EnvConfig& config, const character::Character& character);
// The same, loading the config's character (for tools that need only the sizes and names).
EnvSpec MakeEnvSpec(const EnvConfig& config);

// The task `config` asks for on top of imitation (the Task defaults: imitation alone).
std::unique_ptr<Task> MakeTask(const EnvConfig& config);

// Why an episode ended.
enum class EpisodeEnd {
  kRunning,
  kFell,       // a body outside allowed_contacts touched the ground (terminated)
  kStrayed,    // the root left the reference by more than max_root_distance (terminated)
  kUnstable,   // the simulation diverged (terminated; counted in unstable_resets())
  kTimeLimit,  // max_episode_steps reached (truncated)
  kClipEnd,    // a clip that does not loop ran out (truncated)
};

struct StepResult {
  double reward = 0;
  RewardTerms terms;
  bool terminated = false;  // the episode ended in a failure state: its value is 0
  bool truncated = false;   // the episode was cut short: bootstrap from the final observation
};

struct EpisodeStats {
  double episode_return = 0;
  // episode_return / (max reward per step * the longest this episode could have run)
  double normalized_return = 0;
  int length = 0;
  int max_length = 0;
  RewardTerms mean_terms;       // per-step mean of each term
  std::vector<double> figures;  // per-step means, as EnvSpec::figure_names names them
  EpisodeEnd end = EpisodeEnd::kRunning;
  int task_falls = 0;  // falls a task that gets up saw (Task::falls); the episode went on
  // Whether it ended in a failure state.
  bool ended_in_fall() const {
    return end == EpisodeEnd::kFell || end == EpisodeEnd::kStrayed || end == EpisodeEnd::kUnstable;
  }
  // Whether the character fell at all: ending the episode, or to get up again.
  bool fell() const { return ended_in_fall() || task_falls > 0; }
};

class ImitationEnv final : public TaskHost {
 public:
  // The character's model timestep must equal config.physics_dt() (load it with
  // Character::Load(path, config.physics_dt())). Throws ConfigError for names in the config
  // that the character lacks.
  ImitationEnv(std::shared_ptr<const character::Character> character,
               std::shared_ptr<const character::MotionClip> clip, const EnvConfig& config,
               uint64_t seed);
  // With config.steering: the steering task on `motions` (LoadMotionSet). Without, `motions`
  // holds the one clip. `task` replaces the config's (MakeTask) when given.
  ImitationEnv(std::shared_ptr<const character::Character> character,
               std::shared_ptr<const MotionSet> motions, const EnvConfig& config, uint64_t seed,
               std::unique_ptr<Task> task = nullptr);

  const EnvSpec& spec() const { return spec_; }
  // The task on top of imitation (Steering() reaches the steering task's commands).
  Task& task() { return *task_; }
  const Task& task() const { return *task_; }

  // Starts an episode in the reference state (pose and velocities) at a random phase, or at
  // config.start_phase when random_start is off. Writes the first observation.
  void Reset(float* observation);
  void ResetAtPhase(double phase, float* observation);

  // Applies `action` (spec().action_size values, clipped to [-1, 1]; non-finite values count in
  // bad_actions() and act as 0) for one control step of config.substeps physics steps, and
  // writes the next observation. After a step that terminates or truncates, call Reset.
  StepResult Step(const float* action, float* observation);

  // The current episode so far (complete once a step has ended it).
  const EpisodeStats& episode() const { return episode_; }
  // The action that sets every PD target to the reference pose of the next control step: the
  // "PD tracking, no learning" baseline.
  void ReferenceAction(float* action) const;

  // An external force (world frame, newtons) on a body's centre of mass, applied in every
  // physics step until changed; a reset clears it. For perturbation trials.
  void SetExternalForce(int body, const character::Vec3& force);
  // Replaces the simulated state (for tests and perturbation tools); keeps the episode going.
  void SetState(const double* qpos, const double* qvel) override;
  const mjData& data() const override { return *data_; }
  const character::Character& character() const override { return *character_; }
  // The clip imitated now (steering: the current command's clip, or a transition).
  const character::MotionClip& clip() const override { return *clip_; }
  // The bodies that may touch the ground (the config's list, or the clip's when it says auto).
  const std::vector<std::string>& allowed_contacts() const { return config_.allowed_contacts; }
  double time() const override { return time_; }
  double phase() const { return clip_->Phase(time_); }
  // The pushes of EnvConfig::perturbations (nullptr without), for tests and tools.
  const Perturbations* perturbations() const { return perturbations_.get(); }
  int64_t bad_actions() const { return bad_actions_; }
  int64_t unstable_resets() const { return unstable_resets_; }

  // The clips the reference is drawn from (one without a task that switches them), and the
  // entry imitated now.
  const MotionSet& motion_set() const override { return *motions_; }
  int reference_entry() const override { return reference_entry_; }
  // The character's yaw, radians, and its centre of mass, world.
  double heading() const override;
  character::Vec3 CentreOfMass() const override;
  // Rewrites the current observation (after a command, which changes the task's part).
  void Observe(float* observation) const { WriteObservation(observation); }
  void SwitchReference(int entry) override;

  // Joint coordinates and velocities of the reference at clip time `time` (nq and nv values).
  void ReferenceState(double time, double* qpos, double* qvel) const;
  // The reward of the current simulated state against the reference at clip time `time` (Step
  // scores against the reference at the end of the step).
  RewardTerms RewardAt(double time);

 private:
  // The clip's own state at `time`, before the reference frame (ReferenceState applies it).
  void ClipState(double time, double* qpos, double* qvel) const;
  // At the start of a new cycle, moves the reference frame onto the character
  // (EnvConfig::reference_sync; facing the task's reference_heading() when it has one).
  void SyncReference(double time);
  void WriteObservation(float* observation) const;
  void Features(const mjData& d, PoseFeatures* out) const;
  // Scores data_ against the reference state already in ref_data_.
  RewardTerms Score();
  bool Diverged() const;
  EpisodeEnd CheckTermination() const;
  // The pieces of Step, in its order.
  void SetJointTargets(const float* action);
  void ApplyPushes();
  void AdvanceReference(double next_time);
  StepResult ScoreStep();
  void UpdateEpisode(const StepResult& result, int falls_before);

  std::shared_ptr<const character::Character> character_;
  std::shared_ptr<const MotionSet> motions_;
  int reference_entry_ = 0;
  const character::MotionClip* clip_ = nullptr;  // motions_'s reference_entry_
  EnvConfig config_;
  EnvSpec spec_;
  std::mt19937_64 rng_;
  character::DataPtr data_;
  character::DataPtr ref_data_;         // the reference pose, kinematics only
  std::vector<double> joint_weights_;   // per skeleton joint
  std::vector<int> hinge_joint_;        // skeleton joint of each actuated hinge
  std::vector<char> may_touch_ground_;  // per body
  // Reference joint coordinates just before and after a time, for velocities by differences.
  mutable std::vector<double> qpos_before_, qpos_after_;
  std::vector<double> qvel_scratch_;
  mutable character::Pose pose_scratch_;
  PoseFeatures sim_features_, ref_features_;
  double time_ = 0;
  // Where the reference is drawn: the clip turned by reference_yaw_ about the vertical and moved
  // by reference_offset_ horizontally; identity at every reset.
  double reference_yaw_ = 0;
  double reference_offset_[2] = {0, 0};
  EpisodeStats episode_;
  RewardTerms term_sums_;
  int64_t bad_actions_ = 0;
  int64_t unstable_resets_ = 0;
  std::unique_ptr<Task> task_;
  std::unique_ptr<Perturbations> perturbations_;  // with EnvConfig::perturbations
  int imitation_observation_size_ = 0;
};

const char* EpisodeEndName(EpisodeEnd end);

}  // namespace ragdoll::sim
