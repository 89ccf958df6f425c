// A task on top of imitation (DeepMimic's steering, recovery from a fall, pushes survived): an
// object that adds its part of the observation, its reward term, its per-step advance and reset,
// and its named episode figures to the imitation environment. The defaults are imitation alone,
// so a new task is a new file that overrides what it adds. It is built from the config alone (the
// environment's spec is known before any environment exists); the environment passes itself.
#pragma once

#include <optional>
#include <random>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"
#include "sim/imitation_reward.h"
#include "sim/motion_set.h"

namespace ragdoll::sim {

// What a task may read of the environment and the two things it may change: which clip of the
// motion set is imitated, and the state an episode starts in.
class TaskHost {
 public:
  virtual const character::Character& character() const = 0;
  // The simulated state (positions and velocities current, as after mj_forward).
  virtual const mjData& data() const = 0;
  // The character's yaw, radians.
  virtual double heading() const = 0;
  virtual character::Vec3 CentreOfMass() const = 0;
  virtual const MotionSet& motion_set() const = 0;
  // Replaces the simulated state (a task that starts its episodes fallen).
  virtual void SetState(const double* qpos, const double* qvel) = 0;
  // The motion-set entry imitated now, its clip and the time in it, s.
  virtual int reference_entry() const = 0;
  virtual const character::MotionClip& clip() const = 0;
  virtual double time() const = 0;
  // The reference becomes `entry`'s clip at the key frame whose pose is closest to the
  // character's, placed on the character (facing Task::reference_heading() when it has one).
  virtual void SwitchReference(int entry) = 0;

 protected:
  ~TaskHost() = default;
};

// An episode figure: its name (a column of the learner's log, a metric label, a key of the
// evaluation) and its unit ("m/s", "rad"; the evaluation shows radians in degrees).
struct FigureSpec {
  std::string name;
  std::string unit;
};

class Task {
 public:
  virtual ~Task() = default;

  // How the evaluation groups its figures ("steering"); empty for imitation alone.
  virtual std::string name() const { return {}; }

  // Observation entries written after the imitation ones, and a name for each.
  virtual int observation_size() const { return 0; }
  virtual std::vector<std::string> ObservationNames() const { return {}; }
  virtual void WriteObservation(const TaskHost& /*env*/, float* /*out*/) const {}

  // The name of its reward term among the episode figures (after the imitation terms); empty
  // when it adds none. Its largest value per step goes into the normalised return.
  virtual std::string reward_term() const { return {}; }
  virtual double max_reward() const { return 0; }
  // Its own episode figures (per-step means), after every reward term.
  virtual std::vector<FigureSpec> FigureSpecs() const { return {}; }

  // Throws std::invalid_argument when `set` is not the motion set the config describes.
  virtual void Check(const MotionSet& /*set*/) const {}

  // Reset: called before the start phase is drawn (Reset only, not ResetAtPhase).
  virtual void ChooseEpisode(const TaskHost& /*env*/, std::mt19937_64& /*rng*/) {}
  // The motion-set entry an episode starts in.
  virtual int StartEntry(const MotionSet& set) const { return set.commands().front(); }
  // Whether an episode of a clip that does not loop ends with the clip (a task that switches
  // clips runs to the time limit).
  virtual bool ends_with_clip() const { return true; }
  // Called once the episode's first state is set, before its first observation.
  virtual void Start(TaskHost& /*env*/, std::mt19937_64& /*rng*/) {}

  // After the physics of a step, with the clip time advanced. True when it decided the reference
  // itself this step (the environment then leaves it where the task put it).
  virtual bool Advance(TaskHost& /*env*/, std::mt19937_64& /*rng*/) { return false; }
  // A get-up has handed back (RecoveryTask): the task takes up from where the character stands;
  // its reference is switched to ResumeEntry right after.
  virtual void Resume(TaskHost& /*env*/) {}
  // The entry a get-up, which ends standing, hands back to.
  virtual int ResumeEntry(const MotionSet& set) const { return StartEntry(set); }
  // Whether a body outside allowed_contacts touching the ground, or the root straying from the
  // reference, ends the episode (DeepMimic's early termination); a task that gets up does not.
  virtual bool falls_end_episode() const { return true; }
  // Its own failure state (one that gets up: still down long after a fall), which ends the
  // episode as a fall.
  virtual bool failed() const { return false; }
  // Falls seen this episode by a task that keeps episodes going through them.
  virtual int falls() const { return 0; }
  // How much the imitation reward counts this step (getting up counts less, so falling costs).
  virtual double imitation_scale() const { return 1.0; }
  // The yaw the reference faces whenever it is placed on the character; none: the config's
  // reference_sync decides.
  virtual std::optional<double> reference_heading() const { return std::nullopt; }
  // Its reward term for the step just taken (0 without one); `character` holds the features of
  // the simulated state the imitation terms were computed from. Also accumulates its figures.
  virtual double Reward(const TaskHost& /*env*/, const PoseFeatures& /*character*/) { return 0; }
  // Per-step means of its figures over the episode's `steps` steps, in FigureSpecs' order.
  virtual void Figures(double /*steps*/, double* /*out*/) const {}
};

}  // namespace ragdoll::sim
