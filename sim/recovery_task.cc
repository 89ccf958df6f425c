#include "sim/recovery_task.h"

#include <stdexcept>

#include "character/ground_contacts.h"
#include "sim/falls.h"

namespace ragdoll::sim {

RecoveryTask::RecoveryTask(const EnvConfig& config, std::unique_ptr<Task> inner)
    : config_(config.recovery), inner_(std::move(inner)), control_dt_(config.control_dt()) {
  if (!config_.enabled()) throw std::invalid_argument("a recovery task needs get-up clips");
  inner_figures_ = static_cast<int>(inner_->FigureSpecs().size());
}

std::vector<std::string> RecoveryTask::ObservationNames() const {
  std::vector<std::string> names = inner_->ObservationNames();
  names.push_back("recovery.face_down");
  names.push_back("recovery.face_up");
  return names;
}

void RecoveryTask::WriteObservation(const TaskHost& env, float* out) const {
  inner_->WriteObservation(env, out);
  out += inner_->observation_size();
  out[0] = get_up_entry_ >= 0 && get_up_entry_ == face_down_ ? 1.0f : 0.0f;
  out[1] = get_up_entry_ >= 0 && get_up_entry_ == face_up_ ? 1.0f : 0.0f;
}

std::vector<FigureSpec> RecoveryTask::FigureSpecs() const {
  std::vector<FigureSpec> figures = inner_->FigureSpecs();
  figures.push_back({"falls", "count"});
  figures.push_back({"getting_up", "share"});
  return figures;
}

void RecoveryTask::Check(const MotionSet& set) const {
  inner_->Check(set);
  for (const char* name : {"get_up_face_down", "get_up_face_up"}) {
    const int entry = set.Find(name);
    if (entry < 0 || !set.entry(entry).get_up) {
      throw std::invalid_argument(std::string("the motion set has no get-up clip '") + name + "'");
    }
  }
}

void RecoveryTask::ChooseEpisode(const TaskHost& env, std::mt19937_64& rng) {
  inner_->ChooseEpisode(env, rng);
  const double u = std::uniform_real_distribution<double>(0, 1)(rng);
  start_ = u < config_.start_fallen                              ? Beginning::kFallen
           : u < config_.start_fallen + config_.start_getting_up ? Beginning::kGettingUp
                                                                 : Beginning::kStanding;
  if (start_ == Beginning::kGettingUp) {
    const MotionSet& set = env.motion_set();
    start_entry_ =
        set.Find(std::bernoulli_distribution(0.5)(rng) ? "get_up_face_down" : "get_up_face_up");
  }
}

int RecoveryTask::StartEntry(const MotionSet& set) const {
  return start_ == Beginning::kGettingUp ? start_entry_ : inner_->StartEntry(set);
}

void RecoveryTask::Start(TaskHost& env, std::mt19937_64& rng) {
  const MotionSet& set = env.motion_set();
  if (may_touch_ground_.empty()) {
    face_down_ = set.Find("get_up_face_down");
    face_up_ = set.Find("get_up_face_up");
    const character::Character& character = env.character();
    may_touch_ground_.assign(character.model()->nbody, 0);
    for (const std::string& body : GroundContacts(set, character)) {
      may_touch_ground_[mj_name2id(character.model(), mjOBJ_BODY, body.c_str())] = 1;
    }
    const character::MotionClip& base = *set.entry(inner_->StartEntry(set)).clip;
    stand_height_ = StandHeight(base);
    // Only early_termination looks at which bodies a get-up lets touch the floor.
    get_up_may_touch_.assign(set.size(), {});
    for (int entry : {face_down_, face_up_}) {
      if (!config_.early_termination) continue;
      std::vector<char>& may_touch = get_up_may_touch_[entry];
      may_touch = may_touch_ground_;
      for (const auto& [body, share] : character::GroundContactFractions(
               *set.entry(entry).clip, character, config_.early_termination_height)) {
        may_touch[mj_name2id(character.model(), mjOBJ_BODY, body.c_str())] = 1;
      }
    }
  }
  get_up_failed_ = false;
  lying_on_.assign(env.character().model()->nbody, 0);
  falls_ = 0;
  recovering_steps_ = 0;
  down_steps_ = 0;
  get_up_entry_ = -1;
  inner_->Start(env, rng);
  if (start_ == Beginning::kGettingUp) {
    get_up_entry_ = start_entry_;
  } else if (start_ == Beginning::kFallen) {
    const FallenState fallen =
        SettledFall(env.character(), *set.entry(inner_->StartEntry(set)).clip, rng);
    env.SetState(fallen.qpos.data(), fallen.qvel.data());
    GetUp(env);
    falls_ = 0;  // a start, not a fall
  }
  // Until the next ChooseEpisode: a reset at a given phase starts standing.
  start_ = Beginning::kStanding;
}

bool GetUpContactFails(bool settling, const std::vector<char>& on_ground,
                       const std::vector<char>& may_touch, std::vector<char>* lying) {
  bool fails = false;
  for (size_t b = 0; b < on_ground.size(); ++b) {
    (*lying)[b] = settling ? (*lying)[b] || on_ground[b] : (*lying)[b] && on_ground[b];
    fails = fails || (on_ground[b] && !may_touch[b] && !(*lying)[b]);
  }
  return fails;
}

bool RecoveryTask::Fallen(const TaskHost& env) {
  return character::TouchesGroundOutside(env.character().model(), env.data(), may_touch_ground_);
}

void RecoveryTask::GetUp(TaskHost& env) {
  // Which way the trunk's front (+x) points: at the floor, the get-up from lying face down.
  const double front_z = env.data().xmat[9 * env.character().root_body() + 6];
  if (get_up_entry_ < 0) {
    ++falls_;
    down_steps_ = 0;
    character::BodiesOnGround(env.character().model(), env.data(), &lying_on_);
  }
  get_up_entry_ = front_z < 0 ? face_down_ : face_up_;
  env.SwitchReference(get_up_entry_);
}

bool RecoveryTask::Advance(TaskHost& env, std::mt19937_64& rng) {
  if (get_up_entry_ < 0) {
    if (!Fallen(env)) return inner_->Advance(env, rng);
    GetUp(env);
    return true;
  }
  ++recovering_steps_;
  ++down_steps_;
  if (config_.early_termination) {
    character::BodiesOnGround(env.character().model(), env.data(), &on_ground_);
    const bool settling = down_steps_ * control_dt_ <= kSettleSeconds;
    if (GetUpContactFails(settling, on_ground_, get_up_may_touch_[get_up_entry_], &lying_on_)) {
      get_up_failed_ = true;
    }
  }
  if (env.time() < env.clip().duration() - 1e-9) return false;
  // The get-up has played: standing, the task underneath leads again; if not, get up again
  // from where the character is.
  if (PostureOf(env.character(), env.data(), stand_height_) == Posture::kStanding) {
    get_up_entry_ = -1;
    inner_->Resume(env);  // first: the reference is placed facing the heading it resumes with
    env.SwitchReference(inner_->ResumeEntry(env.motion_set()));
  } else if (config_.early_termination) {
    // Entered again, the get-up's easy middle would pay for missing its hard end.
    get_up_failed_ = true;
  } else {
    GetUp(env);
  }
  return true;
}

bool RecoveryTask::failed() const {
  return get_up_entry_ >= 0 &&
         (get_up_failed_ || down_steps_ * control_dt_ > config_.give_up_after);
}

std::optional<double> RecoveryTask::reference_heading() const {
  if (get_up_entry_ >= 0) return std::nullopt;
  return inner_->reference_heading();
}

double RecoveryTask::imitation_scale() const {
  return get_up_entry_ >= 0 ? config_.get_up_reward_scale : inner_->imitation_scale();
}

double RecoveryTask::Reward(const TaskHost& env, const PoseFeatures& character) {
  return get_up_entry_ >= 0 ? 0.0 : inner_->Reward(env, character);
}

void RecoveryTask::Figures(double steps, double* out) const {
  inner_->Figures(steps, out);
  out += inner_figures_;
  out[0] = falls_;
  out[1] = recovering_steps_ / steps;
}

}  // namespace ragdoll::sim
