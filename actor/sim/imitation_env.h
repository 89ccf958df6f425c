// The imitation environment: a MuJoCo ragdoll rewarded for following a reference clip
// (DeepMimic). Three methods, as in EnvPool: Reset, Step, spec().
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "actor/sim/character.h"
#include "actor/sim/env_config.h"
#include "actor/sim/imitation_reward.h"
#include "actor/sim/motion_clip.h"
#include "actor/sim/motion_set.h"

namespace ragdoll::sim {

struct EnvSpec {
  int observation_size = 0;
  int action_size = 0;
  std::vector<std::string> observation_names;
  std::vector<std::string> action_names;  // one per actuated hinge
  double control_dt = 0;
  int max_episode_steps = 0;
  double max_reward_per_step = 0;
};

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
  RewardTerms mean_terms;  // per-step mean of each term
  // Steering: per-step means of |v - v*| (m/s) and |heading - desired| (rad); 0 without.
  double speed_error = 0;
  double heading_error = 0;
  EpisodeEnd end = EpisodeEnd::kRunning;
  bool fell() const {
    return end == EpisodeEnd::kFell || end == EpisodeEnd::kStrayed || end == EpisodeEnd::kUnstable;
  }
};

class ImitationEnv {
 public:
  // The character's model timestep must equal config.physics_dt() (load it with
  // Character::Load(path, config.physics_dt())). Throws ConfigError for names in the config
  // that the character lacks.
  ImitationEnv(std::shared_ptr<const Character> character, std::shared_ptr<const MotionClip> clip,
               const EnvConfig& config, uint64_t seed);
  // With config.steering: the steering task on `motions` (LoadMotionSet). Without, `motions`
  // holds the one clip.
  ImitationEnv(std::shared_ptr<const Character> character, std::shared_ptr<const MotionSet> motions,
               const EnvConfig& config, uint64_t seed);

  const EnvSpec& spec() const { return spec_; }

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
  void SetExternalForce(int body, const Vec3& force);
  // Replaces the simulated state (for tests and perturbation tools); keeps the episode going.
  void SetState(const double* qpos, const double* qvel);
  const mjData& data() const { return *data_; }
  const Character& character() const { return *character_; }
  // The clip imitated now (steering: the current command's clip, or a transition).
  const MotionClip& clip() const { return *clip_; }
  // The bodies that may touch the ground (the config's list, or the clip's when it says auto).
  const std::vector<std::string>& allowed_contacts() const { return config_.allowed_contacts; }
  double time() const { return time_; }
  double phase() const { return clip_->Phase(time_); }
  int64_t bad_actions() const { return bad_actions_; }
  int64_t unstable_resets() const { return unstable_resets_; }

  // --- steering (EnvConfig::steering); the command is fixed without it ---
  bool steering() const { return steering_; }
  const MotionSet& motion_set() const { return *motions_; }
  // The motion-set entry the current command names, and the one whose clip is imitated now (a
  // transition while one plays).
  int command_entry() const { return command_entry_; }
  int reference_entry() const { return reference_entry_; }
  const Command& command() const { return command_; }
  // Commands a script or a player gives: from now on the command changes only through here
  // (training changes it at random times). Switches the reference clip as a random change does.
  void SetCommand(int entry);
  // The yaw the character should face (integrates the command's turn), its own yaw, radians.
  double desired_heading() const { return desired_heading_; }
  double heading() const;
  // Horizontal centre-of-mass velocity averaged over the last velocity_window seconds, world.
  Vec3 TravelVelocity() const;
  // |TravelVelocity() - commanded velocity| (m/s) and the heading error wrapped to [-pi, pi].
  double SpeedError() const;
  double HeadingError() const;
  // Rewrites the current observation (after SetCommand, which changes its command part).
  void Observe(float* observation) const { WriteObservation(observation); }
  // Seconds since the episode started.
  double episode_time() const { return episode_time_; }

  // Joint coordinates and velocities of the reference at clip time `time` (nq and nv values).
  void ReferenceState(double time, double* qpos, double* qvel) const;
  // The reward of the current simulated state against the reference at clip time `time` (Step
  // scores against the reference at the end of the step).
  RewardTerms RewardAt(double time);

 private:
  // The clip's own state at `time`, before the reference frame (ReferenceState applies it).
  void ClipState(double time, double* qpos, double* qvel) const;
  // At the start of a new cycle, moves the reference frame onto the character
  // (EnvConfig::reference_sync).
  void SyncReference(double time);
  // Steering: the reference becomes `entry`'s clip at the time whose pose is closest to the
  // character's, placed on the character and facing the desired heading.
  void SwitchReference(int entry);
  // Makes `entry` the command and switches the reference (through a transition where the set
  // has one); false when it already is.
  bool ChangeCommand(int entry);
  // Steering, after the physics of a step: time, heading, command changes.
  void AdvanceTask(double next_time);
  void StartCommandHistory();
  void WriteObservation(float* observation) const;
  double TaskReward(RewardTerms* terms) const;
  int RandomCommand();
  void Features(const mjData& d, PoseFeatures* out) const;
  // Scores data_ against the reference state already in ref_data_.
  RewardTerms Score();
  bool Diverged() const;
  EpisodeEnd CheckTermination() const;

  std::shared_ptr<const Character> character_;
  std::shared_ptr<const MotionSet> motions_;
  const MotionClip* clip_ = nullptr;  // motions_'s reference_entry_
  EnvConfig config_;
  EnvSpec spec_;
  std::mt19937_64 rng_;
  DataPtr data_;
  DataPtr ref_data_;                    // the reference pose, kinematics only
  std::vector<double> joint_weights_;   // per skeleton joint
  std::vector<int> hinge_joint_;        // skeleton joint of each actuated hinge
  std::vector<char> may_touch_ground_;  // per body
  // Reference joint coordinates just before and after a time, for velocities by differences.
  mutable std::vector<double> qpos_before_, qpos_after_;
  std::vector<double> qvel_scratch_;
  mutable Pose pose_scratch_;
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
  // Steering.
  bool steering_ = false;
  bool random_commands_ = true;
  int command_entry_ = 0;
  int reference_entry_ = 0;
  Command command_;
  double desired_heading_ = 0;
  double episode_time_ = 0;
  double next_command_time_ = 0;
  std::vector<Vec3> com_history_;  // ring of the last window + 1 control steps' centre of mass
  int com_head_ = 0;
  double error_sums_[2] = {0, 0};  // speed, heading
};

// Observation entries the steering task adds after ObservationSize(character) (0 without).
int SteeringObservationSize(const EnvConfig& config);

const char* EpisodeEndName(EpisodeEnd end);

}  // namespace ragdoll::sim
