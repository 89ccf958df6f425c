// The steering task (EnvConfig::steering): one policy follows commands, imitating the motion-set
// clip that demonstrates the current command, rewarded also for tracking the commanded velocity
// and heading (DeepMimic's imitation + task reward).
#pragma once

#include <string>
#include <vector>

#include "sim/env_config.h"
#include "sim/task.h"

namespace ragdoll::sim {

class ImitationEnv;

class SteeringTask final : public Task {
 public:
  // config.steering must be enabled.
  explicit SteeringTask(const EnvConfig& config);

  // The commanded velocity and the desired heading seen from the character's heading frame (5),
  // then which clip of the set is imitated now (one-hot).
  std::string name() const override { return "steering"; }
  int observation_size() const override;
  std::vector<std::string> ObservationNames() const override;
  void WriteObservation(const TaskHost& env, float* out) const override;
  std::string reward_term() const override { return "task"; }
  double max_reward() const override { return config_.MaxReward(); }
  // Per-step means of |v - v*| (m/s) and |heading - desired| (rad).
  std::vector<FigureSpec> FigureSpecs() const override {
    return {{"speed_error", "m/s"}, {"heading_error", "rad"}};
  }

  void Check(const MotionSet& set) const override;
  void ChooseEpisode(const TaskHost& env, std::mt19937_64& rng) override;
  // The episode starts in the command's own clip.
  int StartEntry(const MotionSet& /*set*/) const override { return command_entry_; }
  bool ends_with_clip() const override { return false; }
  void Start(TaskHost& env, std::mt19937_64& rng) override;
  // Turns the desired heading; ends a transition that has played, the stand after a get-up or a
  // catch step, starts a catch step, or changes the command when its time has come.
  bool Advance(TaskHost& env, std::mt19937_64& rng) override;
  // After a get-up: the desired heading is where the character faces, the travel history new;
  // the character stands for `recovery.stand_after_get_up` before the command leads again.
  void Resume(TaskHost& env) override;
  // Standing while it stands after a get-up; else the transition from standing to the command
  // where the set has one (a get-up ends standing, and the command's clip may be mid-stride), else
  // the command's clip.
  int ResumeEntry(const MotionSet& set) const override;
  // The reference faces where the character is told to face.
  std::optional<double> reference_heading() const override { return desired_heading_; }
  double Reward(const TaskHost& env, const PoseFeatures& character) override;
  void Figures(double steps, double* out) const override;

  // The motion-set entry the current command names.
  int command_entry() const { return command_entry_; }
  const Command& command() const { return command_; }
  // Commands a script or a player gives: from now on the command changes only through here
  // (training changes it at random times). Switches the reference clip as a random change does.
  // Throws std::invalid_argument for an entry that is not a command of the set.
  void SetCommand(TaskHost& env, int entry);
  // Whether it is standing after a get-up, the command waiting.
  bool standing_after_get_up() const { return episode_time_ < stand_until_ - 1e-9; }
  // The clip a catch step imitates now (SteeringConfig::catch_above), or -1.
  int catching() const { return catching_; }
  // The yaw the character should face (integrates the command's turn), radians.
  double desired_heading() const { return desired_heading_; }
  // Horizontal centre-of-mass velocity averaged over the last velocity_window seconds, world.
  character::Vec3 TravelVelocity() const;
  // |TravelVelocity() - commanded velocity| (m/s) and the heading error wrapped to [-pi, pi]:
  // against the command given, also while the character stands after a get-up.
  double SpeedError() const;
  double HeadingError(const TaskHost& env) const;
  // Seconds since the episode started.
  double episode_time() const { return episode_time_; }

 private:
  // Makes `entry` the command and switches the reference (through a transition where the set
  // has one); false when it already is.
  bool ChangeCommand(TaskHost& env, int entry);
  int RandomCommand(const MotionSet& set, std::mt19937_64& rng) const;
  // The desired heading and the travel history from the character's state now.
  void FaceAndTravelAsNow(const TaskHost& env);
  // What the character is asked to do now: stand while it stands after a get-up, else the command.
  const Command& Asked() const { return standing_after_get_up() ? standing_ : command_; }
  double SpeedErrorFrom(const Command& command) const;
  // The reference onto the clip of what is asked now (the stand after a get-up, else the
  // command) from wherever it is, through a transition from the clip imitated where the set has
  // one.
  void Lead(TaskHost& env);
  // Starts or ends a catch step; true when it switched the reference.
  bool CatchStep(TaskHost& env);

  SteeringConfig config_;
  double control_dt_;
  double stand_after_get_up_;  // s
  int stand_entry_ = 0;        // the set's command nearest to standing still
  Command standing_;           // its command
  double stand_until_ = -1;    // episode time the stand after a get-up ends
  bool resume_pending_ = false;
  int catching_ = -1;       // the clip of the catch step under way
  double catch_until_ = 0;  // episode time it ends
  bool random_commands_ = true;
  int command_entry_ = 0;
  Command command_;
  double desired_heading_ = 0;
  double episode_time_ = 0;
  double next_command_time_ = 0;
  std::vector<character::Vec3>
      com_history_;  // ring of the last window + 1 control steps' centre of mass
  int com_head_ = 0;
  double error_sums_[2] = {0, 0};  // speed, heading
};

// The steering task of `env`, for the tools that give commands and read its state. Throws
// std::logic_error when the environment has none.
SteeringTask& Steering(ImitationEnv& env);
const SteeringTask& Steering(const ImitationEnv& env);

}  // namespace ragdoll::sim
