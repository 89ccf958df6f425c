// Falling and getting up (EnvConfig::recovery), on top of another task: a fall, seen in the state,
// switches the reference to the get-up clip for how the character lies; once the clip has played
// and the character stands, the reference hands back to the task underneath. Falls do not end
// episodes; episodes may also start fallen or part-way through a get-up.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/env_config.h"
#include "sim/task.h"

namespace ragdoll::sim {

// Early termination's contact rule for one control step of a get-up, per body: `lying` (bodies
// excused) takes in every body on the floor while `settling` and after keeps only those still on
// it; true when a body touches that `may_touch` does not allow and `lying` does not excuse.
bool GetUpContactFails(bool settling, const std::vector<char>& on_ground,
                       const std::vector<char>& may_touch, std::vector<char>* lying);

class RecoveryTask final : public Task {
 public:
  // config.recovery must be enabled; `inner` is the task recovered to (imitation alone, or
  // steering).
  RecoveryTask(const EnvConfig& config, std::unique_ptr<Task> inner);

  const Task& inner() const { return *inner_; }
  Task& inner() { return *inner_; }

  // The inner task's name (its figures are grouped under it), or "get_up" on imitation alone
  // (the evaluation's "recovery" holds the recovery trials).
  std::string name() const override { return inner_->name().empty() ? "get_up" : inner_->name(); }
  // The inner task's observation, then which get-up clip is imitated (one-hot: face down, face
  // up; both 0 while not getting up).
  int observation_size() const override { return inner_->observation_size() + 2; }
  std::vector<std::string> ObservationNames() const override;
  void WriteObservation(const TaskHost& env, float* out) const override;
  std::string reward_term() const override { return inner_->reward_term(); }
  double max_reward() const override { return inner_->max_reward(); }
  // The inner task's figures, then falls per episode and the share of its steps spent getting up.
  std::vector<FigureSpec> FigureSpecs() const override;

  void Check(const MotionSet& set) const override;
  void ChooseEpisode(const TaskHost& env, std::mt19937_64& rng) override;
  int StartEntry(const MotionSet& set) const override;
  bool ends_with_clip() const override { return false; }
  void Start(TaskHost& env, std::mt19937_64& rng) override;
  bool Advance(TaskHost& env, std::mt19937_64& rng) override;
  std::optional<double> reference_heading() const override;
  bool falls_end_episode() const override { return false; }
  // Still getting up config.recovery.give_up_after seconds after the get-up began, or (with
  // early_termination) touched the floor with a body the get-up clip keeps off it.
  bool failed() const override;
  double imitation_scale() const override;
  double Reward(const TaskHost& env, const PoseFeatures& character) override;
  void Figures(double steps, double* out) const override;

  bool recovering() const { return get_up_entry_ >= 0; }
  int falls() const override { return falls_; }

 private:
  enum class Beginning { kStanding, kFallen, kGettingUp };
  // Whether a body the base clips keep off the floor touches it.
  bool Fallen(const TaskHost& env);
  // The reference becomes the get-up clip for how the character lies, at its closest key frame;
  // a fall when the character was not getting up already.
  void GetUp(TaskHost& env);

  RecoveryConfig config_;
  std::unique_ptr<Task> inner_;
  int inner_figures_ = 0;
  std::vector<char> may_touch_ground_;  // per body, from the base clips; filled at the first start
  // Per motion set entry (the get-up clips'), per body: may touch the floor while getting up.
  std::vector<std::vector<char>> get_up_may_touch_;
  bool get_up_failed_ = false;  // early_termination saw the get-up go wrong
  // A fallen body first pushes itself into the get-up's pose: a body on the floor within this
  // long of the fall may lie there until it leaves the floor (early_termination).
  static constexpr double kSettleSeconds = 0.5;
  // Per body: on the floor since the fall (or its first kSettleSeconds) and not lifted since.
  std::vector<char> lying_on_, on_ground_;
  double stand_height_ = 0;  // m: StandHeight of the base clip
  Beginning start_ = Beginning::kStanding;
  int start_entry_ = -1;   // the get-up clip an episode starts in (kGettingUp)
  int get_up_entry_ = -1;  // the get-up clip imitated now; -1: the inner task leads
  int face_down_ = -1, face_up_ = -1;
  double control_dt_;
  int falls_ = 0;
  int recovering_steps_ = 0;
  int down_steps_ = 0;  // since the current get-up began
};

}  // namespace ragdoll::sim
