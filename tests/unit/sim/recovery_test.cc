// Falling and getting up (EnvConfig::recovery, RecoveryTask): the config, the motion set with the
// get-up clips, a fall seen in the state switching the reference, the reward while getting up,
// the hand-back to the walk, and the episodes that start fallen or part-way up.
#include "sim/recovery_task.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "character/ground_contacts.h"
#include "character/motion_io.h"
#include "common/config_section.h"
#include "sim/falls.h"
#include "sim/imitation_env.h"
#include "sim/observation.h"
#include "sim/steering_task.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;
const std::string kFaceDown = kAssets + "/motions/deepmimic/humanoid3d_getup_facedown.txt";
const std::string kFaceUp = kAssets + "/motions/deepmimic/humanoid3d_getup_faceup.txt";

EnvConfig Read(const std::string& yaml) {
  ConfigSection root = ConfigSection::FromString(yaml, "recovery.yaml");
  return ReadEnvConfig(root.Section("environment"), kAssets + "/character/humanoid.xml");
}

std::string ErrorOf(const std::string& yaml) {
  try {
    Read(yaml);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(RecoveryConfigTest, ReadsTheSectionAndNamesWhatIsWrong) {
  const std::string head =
      "environment:\n  motion: motions/walk.json\n  recovery:\n"
      "    face_down: motions/deepmimic/humanoid3d_getup_facedown.txt\n";
  EnvConfig c = Read(head +
                     "    face_up: motions/deepmimic/humanoid3d_getup_faceup.txt\n"
                     "    start_fallen: 0.4\n    start_getting_up: 0.1\n"
                     "    get_up_reward_scale: 0.3\n    early_termination: false\n"
                     "    early_termination_height: 0.05\n    stand_after_get_up: 0.7\n");
  EXPECT_TRUE(c.recovery.enabled());
  EXPECT_EQ(c.recovery.face_down, "motions/deepmimic/humanoid3d_getup_facedown.txt");
  EXPECT_EQ(c.recovery.face_up, "motions/deepmimic/humanoid3d_getup_faceup.txt");
  EXPECT_DOUBLE_EQ(c.recovery.start_fallen, 0.4);
  EXPECT_DOUBLE_EQ(c.recovery.start_getting_up, 0.1);
  EXPECT_DOUBLE_EQ(c.recovery.get_up_reward_scale, 0.3);
  EXPECT_FALSE(c.recovery.early_termination);  // not the defaults, which are read below
  EXPECT_DOUBLE_EQ(c.recovery.early_termination_height, 0.05);
  EXPECT_DOUBLE_EQ(c.recovery.stand_after_get_up, 0.7);
  EXPECT_FALSE(Read("environment:\n  motion: motions/walk.json\n").recovery.enabled());
  const EnvConfig defaults =
      Read(head + "    face_up: motions/deepmimic/humanoid3d_getup_faceup.txt\n");
  EXPECT_TRUE(defaults.recovery.early_termination);
  EXPECT_DOUBLE_EQ(defaults.recovery.early_termination_height, 0.02);
  EXPECT_DOUBLE_EQ(defaults.recovery.stand_after_get_up, 0.0);

  EXPECT_NE(ErrorOf(head).find("face_up"), std::string::npos);
  const std::string both = head + "    face_up: motions/deepmimic/humanoid3d_getup_faceup.txt\n";
  EXPECT_NE(ErrorOf(both + "    start_fallen: 0.7\n    start_getting_up: 0.5\n")
                .find("start_fallen + start_getting_up"),
            std::string::npos);
  EXPECT_NE(ErrorOf(both + "    get_up_reward_scale: 2\n").find("get_up_reward_scale"),
            std::string::npos);
  EXPECT_NE(ErrorOf(both + "    start_falen: 0.2\n").find("start_falen"), std::string::npos);
  EXPECT_NE(ErrorOf(both + "    early_termination_height: 0\n").find("early_termination_height"),
            std::string::npos);
  EXPECT_NE(ErrorOf(both + "    stand_after_get_up: -1\n").find("stand_after_get_up"),
            std::string::npos);
}

class RecoveryEnvTest : public ::testing::Test {
 protected:
  RecoveryEnvTest() {
    config_.character = kAssets + "/character/humanoid.xml";
    config_.motion = kAssets + "/motions/walk.json";
    config_.action_mode = ActionMode::kOffset;
    config_.substeps = 10;
    config_.max_episode_steps = 600;
    config_.recovery.face_down = kFaceDown;
    config_.recovery.face_up = kFaceUp;
    config_.recovery.start_fallen = 0;
    config_.recovery.start_getting_up = 0;
    config_.recovery.early_termination = false;  // the tests of it turn it on
    character_ = character::Character::Load(config_.character, config_.physics_dt());
  }
  std::unique_ptr<ImitationEnv> Make(uint64_t seed = 1) {
    return std::make_unique<ImitationEnv>(character_, LoadMotionSet(config_, *character_), config_,
                                          seed);
  }
  // A steering motion set of the stand and the walk.
  void SteerStandAndWalk() {
    for (const std::string& m : {kAssets + "/motions/stand.json", kAssets + "/motions/walk.json"}) {
      MotionSetItem item;
      item.motion = m;
      item.name = std::filesystem::path(m).stem().string();
      config_.steering.motions.push_back(item);
    }
    config_.motion = config_.steering.motions.front().motion;
  }
  // The same with the stand-to-walk transition.
  void SteerStandWalkAndStart() {
    SteerStandAndWalk();
    MotionSetItem start;
    start.motion = kAssets + "/motions/walk_start.json";
    start.name = "walk_start";
    start.from = "stand";
    start.to = "walk";
    config_.steering.motions.push_back(start);
  }
  const RecoveryTask& Recovery(const ImitationEnv& env) {
    return dynamic_cast<const RecoveryTask&>(env.task());
  }
  // The index of a figure of the environment's spec.
  static int Figure(const ImitationEnv& env, const std::string& name) {
    const auto& names = env.spec().figure_names;
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
  }
  EnvConfig config_;
  std::shared_ptr<const character::Character> character_;
};

// The get-up clips follow the base clip in the set; no command names them and their contacts
// (hands, knees, back) are not among the ones a walk may make.
TEST_F(RecoveryEnvTest, TheGetUpClipsJoinTheMotionSetButNotItsCommandsOrContacts) {
  auto set = LoadMotionSet(config_, *character_);
  ASSERT_EQ(set->size(), 3);
  EXPECT_EQ(set->Find("get_up_face_down"), 1);
  EXPECT_EQ(set->Find("get_up_face_up"), 2);
  EXPECT_TRUE(set->entry(1).get_up && set->entry(2).get_up && !set->entry(0).get_up);
  EXPECT_EQ(set->commands(), std::vector<int>{0});
  EXPECT_EQ(GroundContacts(*set, *character_),
            GroundContacts(MotionSet({set->entry(0)}), *character_));

  auto env = Make();
  EXPECT_EQ(env->spec().observation_size, ObservationSize(*character_) + 2);
  EXPECT_EQ(env->spec().observation_names.back(), "recovery.face_up");
  EXPECT_EQ(env->spec().figure_names.back(), "getting_up");
}

// Laid on its front, the character is seen to have fallen: the episode goes on, the reference
// becomes the face-down get-up turned onto the character, the observation says so, the fall is
// counted, and the imitation reward counts get_up_reward_scale of itself.
TEST_F(RecoveryEnvTest, AFallSwitchesToTheGetUpForHowTheCharacterLies) {
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  EXPECT_EQ(obs[obs.size() - 2], 0.0f);
  EXPECT_EQ(obs[obs.size() - 1], 0.0f);

  std::mt19937_64 rng(5);
  FallenState fallen;
  do {
    fallen = SettledFall(*character_, env->clip(), rng);
  } while (fallen.posture != Posture::kFaceDown);
  env->SetState(fallen.qpos.data(), fallen.qvel.data());
  const StepResult step = env->Step(action.data(), obs.data());
  EXPECT_FALSE(step.terminated || step.truncated);
  EXPECT_EQ(env->reference_entry(), env->motion_set().Find("get_up_face_down"));
  EXPECT_TRUE(Recovery(*env).recovering());
  EXPECT_EQ(obs[obs.size() - 2], 1.0f);
  EXPECT_EQ(obs[obs.size() - 1], 0.0f);
  EXPECT_DOUBLE_EQ(step.reward, config_.recovery.get_up_reward_scale * step.terms.total);
  EXPECT_EQ(env->episode().figures[Figure(*env, "falls")], 1.0);

  // The reference root lies where the character does, its head the same way.
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  env->ReferenceState(env->time(), qpos.data(), qvel.data());
  const double* q = env->data().qpos;
  EXPECT_LT(std::hypot(qpos[0] - q[0], qpos[1] - q[1]), 1e-9);
  EXPECT_LT(
      std::abs(character::WrapAngle(character::BodyYawOf({qpos[3], qpos[4], qpos[5], qpos[6]}) -
                                    character::BodyYawOf({q[3], q[4], q[5], q[6]}))),
      1e-9);

  // Held lying through the whole clip, it is sent through the get-up again: still one fall.
  for (int s = 0; s < 150; ++s) {
    env->SetState(fallen.qpos.data(), fallen.qvel.data());
    ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated);
  }
  EXPECT_TRUE(Recovery(*env).recovering());
  EXPECT_EQ(env->episode().figures[Figure(*env, "falls")], 1.0);
  EXPECT_NEAR(env->episode().figures[Figure(*env, "getting_up")], 150.0 / 151.0, 1e-12);
}

// Still down give_up_after seconds after the fall, the episode ends as a fall.
TEST_F(RecoveryEnvTest, StillDownTooLongEndsTheEpisode) {
  config_.recovery.give_up_after = 2.0;
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  std::mt19937_64 rng(5);
  const FallenState fallen = SettledFall(*character_, env->clip(), rng);
  int steps = 0;
  StepResult step;
  do {
    env->SetState(fallen.qpos.data(), fallen.qvel.data());
    step = env->Step(action.data(), obs.data());
    ++steps;
  } while (!step.terminated && steps < 200);
  EXPECT_TRUE(step.terminated);
  EXPECT_EQ(env->episode().end, EpisodeEnd::kFell);
  EXPECT_EQ(steps, 1 + 61);  // the step that saw the fall, then just over 2 s at 30 Hz
}

// The contact rule by hand: while settling every body on the floor is excused; after, a body
// stays excused only while it stays on the floor; allowed bodies never end the get-up.
TEST(GetUpContactRuleTest, ExcusesWhatTheFallLiesOnUntilItLeavesTheFloor) {
  const std::vector<char> may_touch = {0, 1, 0, 0};  // body 1 (a hand) may touch
  std::vector<char> lying(4, 0);
  EXPECT_FALSE(GetUpContactFails(true, {0, 1, 1, 0}, may_touch, &lying));
  EXPECT_FALSE(GetUpContactFails(true, {0, 0, 0, 1}, may_touch, &lying));  // rolled onto 3
  EXPECT_EQ(lying, (std::vector<char>{0, 1, 1, 1}));
  EXPECT_FALSE(GetUpContactFails(false, {0, 1, 1, 0}, may_touch, &lying));  // 3 lifted
  EXPECT_EQ(lying, (std::vector<char>{0, 1, 1, 0}));
  EXPECT_TRUE(GetUpContactFails(false, {0, 0, 1, 1}, may_touch, &lying));   // 3 down again
  EXPECT_FALSE(GetUpContactFails(false, {0, 1, 0, 0}, may_touch, &lying));  // the hand: allowed
  EXPECT_TRUE(GetUpContactFails(false, {0, 0, 1, 0}, may_touch, &lying));   // 2 came back
}

// Held in settled face-down falls (the state set again before every step) for their settling
// time, the episode goes on with early_termination at G's 2 cm, although each fall rests on a
// body the get-up keeps higher: what the fall lies on is excused. Followed exactly, a get-up is
// never ended by it (its own contacts are allowed).
TEST_F(RecoveryEnvTest, EarlyTerminationExcusesWhatAFallLiesOn) {
  config_.recovery.early_termination = true;
  config_.recovery.early_termination_height = 0.02;
  auto env = Make();
  const MotionSet& set = env->motion_set();
  std::vector<char> may_touch(character_->model()->nbody, 0);
  for (const std::string& body : GroundContacts(set, *character_)) {
    may_touch[mj_name2id(character_->model(), mjOBJ_BODY, body.c_str())] = 1;
  }
  for (const auto& [body, share] : character::GroundContactFractions(
           *set.entry(set.Find("get_up_face_down")).clip, *character_, 0.02)) {
    may_touch[mj_name2id(character_->model(), mjOBJ_BODY, body.c_str())] = 1;
  }
  std::mt19937_64 rng(7);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  std::vector<FallenState> falls;
  while (falls.size() < 6) {
    FallenState fallen = SettledFall(*character_, env->clip(), rng);
    if (fallen.posture == Posture::kFaceDown) falls.push_back(std::move(fallen));
  }
  for (size_t t = 0; t < falls.size(); ++t) {
    const FallenState& fallen = falls[t];
    env->Reset(obs.data());
    env->SetState(fallen.qpos.data(), fallen.qvel.data());
    EXPECT_TRUE(character::TouchesGroundOutside(character_->model(), env->data(), may_touch));
    for (int n = 0; n < 15; ++n) {  // the step that sees the fall, then 0.47 s
      env->SetState(fallen.qpos.data(), fallen.qvel.data());
      ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated) << "fall " << t;
    }
    EXPECT_TRUE(Recovery(*env).recovering());
  }

  config_.recovery.start_getting_up = 1;
  auto up = Make(3);
  up->Reset(obs.data());
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  for (int s = 0; s < 200 && Recovery(*up).recovering(); ++s) {
    up->ReferenceState(up->time(), qpos.data(), qvel.data());
    up->SetState(qpos.data(), qvel.data());
    ASSERT_FALSE(up->Step(action.data(), obs.data()).terminated) << "step " << s;
  }
  EXPECT_FALSE(Recovery(*up).recovering());
}

// A get-up followed exactly (the state set to the reference's at every step) stands at the
// clip's end, and the reference hands back to the walk.
TEST_F(RecoveryEnvTest, AGetUpPlayedThroughHandsBackToTheWalk) {
  config_.recovery.start_getting_up = 1;
  auto env = Make(3);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  ASSERT_TRUE(env->motion_set().entry(env->reference_entry()).get_up);
  ASSERT_TRUE(Recovery(*env).recovering());
  EXPECT_EQ(env->episode().figures[Figure(*env, "falls")], 0.0);  // a start, not a fall
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  int steps = 0;
  while (Recovery(*env).recovering() && steps < 200) {
    env->ReferenceState(env->time(), qpos.data(), qvel.data());
    env->SetState(qpos.data(), qvel.data());
    ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated);
    ++steps;
  }
  EXPECT_FALSE(Recovery(*env).recovering());
  EXPECT_EQ(env->reference_entry(), 0);  // the walk
  EXPECT_EQ(obs[obs.size() - 2] + obs[obs.size() - 1], 0.0f);
  EXPECT_LE(steps * config_.control_dt(), 3.8 + config_.control_dt());
}

// A get-up that reaches its end without the character standing (held in the clip's crouch at
// 1.8 s, its own contacts only) is entered again at its closest key frame; with
// early_termination it ends the episode as a fall, at the clip's end.
TEST_F(RecoveryEnvTest, AGetUpThatEndsWithoutStandingIsEnteredAgainOrWithEarlyTerminationFails) {
  config_.recovery.start_getting_up = 1;
  auto run = [&](bool early_termination) {
    config_.recovery.early_termination = early_termination;
    auto env = Make(3);
    std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
    env->Reset(obs.data());
    std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
    env->ReferenceState(1.8, qpos.data(), qvel.data());
    std::fill(qvel.begin(), qvel.end(), 0.0);
    const double end = env->clip().duration();
    int steps = 0;
    StepResult step;
    while (env->time() < end - 1e-9 && steps < 200) {
      env->SetState(qpos.data(), qvel.data());
      step = env->Step(action.data(), obs.data());
      ASSERT_EQ(step.terminated, env->time() >= end - 1e-9) << "step " << steps;
      ++steps;
    }
    EXPECT_EQ(step.terminated, early_termination);
    EXPECT_EQ(env->episode().end == EpisodeEnd::kFell, early_termination);
    EXPECT_TRUE(Recovery(*env).recovering());
    if (!early_termination) {
      EXPECT_LT(env->time(), end - 1e-9);  // entered again
    }
  };
  run(false);
  run(true);
}

// An episode that starts fallen lies on the floor, getting up, with no fall counted; the same
// seed gives the same episode.
TEST_F(RecoveryEnvTest, EpisodesStartFromSettledFalls) {
  config_.recovery.start_fallen = 1;
  auto a = Make(7), b = Make(7);
  std::vector<float> obs_a(a->spec().observation_size), obs_b(b->spec().observation_size);
  a->Reset(obs_a.data());
  b->Reset(obs_b.data());
  EXPECT_EQ(obs_a, obs_b);
  EXPECT_TRUE(Recovery(*a).recovering());
  EXPECT_TRUE(a->motion_set().entry(a->reference_entry()).get_up);
  EXPECT_LT(a->data().qpos[2], 0.4);
  EXPECT_NE(PostureOf(*character_, a->data(), 0.7), Posture::kStanding);
  EXPECT_EQ(a->episode().task_falls, 0);
}

// A character lying face down (legs straight, as at the end of a get-up) enters the get-up where
// the clip lies too, not at its standing end: the reference pelvis within 0.2 m of its height.
TEST_F(RecoveryEnvTest, AGetUpIsEnteredWhereTheClipLiesAsTheCharacterDoes) {
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  std::mt19937_64 rng(11);
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  for (int trial = 0; trial < 8; ++trial) {
    env->Reset(obs.data());
    const FallenState fallen = SettledFall(*character_, env->clip(), rng);
    env->SetState(fallen.qpos.data(), fallen.qvel.data());
    // Seen at the end of a control step in which a body it may not touch the floor with does.
    for (int s = 0; s < 5 && !Recovery(*env).recovering(); ++s) {
      env->Step(action.data(), obs.data());
    }
    ASSERT_TRUE(Recovery(*env).recovering());
    env->ReferenceState(env->time(), qpos.data(), qvel.data());
    SCOPED_TRACE(PostureName(fallen.posture));
    EXPECT_LT(std::abs(qpos[2] - env->data().qpos[2]), 0.2);
    EXPECT_LT(env->time(), 0.6 * env->clip().duration());
  }
}

// Without recovery, the same fall ends the episode (DeepMimic's early termination).
TEST_F(RecoveryEnvTest, WithoutRecoveryAFallEndsTheEpisode) {
  config_.recovery = {};
  auto env = Make();
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  std::mt19937_64 rng(5);
  const FallenState fallen = SettledFall(*character_, env->clip(), rng);
  env->SetState(fallen.qpos.data(), fallen.qvel.data());
  EXPECT_TRUE(env->Step(action.data(), obs.data()).terminated);
  EXPECT_EQ(env->episode().end, EpisodeEnd::kFell);
}

// On top of steering: the observation is steering's then the get-up's, and a command given while
// getting up waits for the hand-back.
TEST_F(RecoveryEnvTest, SteeringCommandsWaitForTheGetUp) {
  SteerStandAndWalk();
  auto env = Make();
  EXPECT_EQ(env->spec().task, "steering");
  EXPECT_EQ(env->spec().observation_size, ObservationSize(*character_) + 5 + 2 + 2);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  std::mt19937_64 rng(5);
  const FallenState fallen = SettledFall(*character_, env->clip(), rng);
  env->SetState(fallen.qpos.data(), fallen.qvel.data());
  env->Step(action.data(), obs.data());
  ASSERT_TRUE(Recovery(*env).recovering());
  const int get_up = env->reference_entry();
  const int walk = env->motion_set().Find("walk"), stand = env->motion_set().Find("stand");
  const int other = Steering(*env).command_entry() == walk ? stand : walk;
  Steering(*env).SetCommand(*env, other);
  EXPECT_EQ(env->reference_entry(), get_up);
  EXPECT_EQ(Steering(*env).command_entry(), other);
}

// On top of steering, a get-up hands back facing where the character stands: the desired heading
// and the reference's yaw are the character's own, not the heading held before the fall.
TEST_F(RecoveryEnvTest, SteeringTakesUpFromWhereTheGetUpEnds) {
  SteerStandAndWalk();
  config_.recovery.start_getting_up = 1;
  auto env = Make(3);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  ASSERT_TRUE(Recovery(*env).recovering());
  const double heading_before = Steering(*env).desired_heading();
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  for (int steps = 0; Recovery(*env).recovering() && steps < 200; ++steps) {
    env->ReferenceState(env->time(), qpos.data(), qvel.data());
    // The get-up played turned a quarter to the left, as a fall leaves a character anywhere.
    const character::Quat yaw = character::AxisAngle({0, 0, 1}, M_PI / 2);
    const character::Vec3 p = character::Rotate(yaw, {qpos[0], qpos[1], qpos[2]});
    const character::Quat r = character::Multiply(yaw, {qpos[3], qpos[4], qpos[5], qpos[6]});
    std::copy(p.begin(), p.end(), qpos.begin());
    std::copy(r.begin(), r.end(), qpos.begin() + 3);
    env->SetState(qpos.data(), qvel.data());
    ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated);
  }
  ASSERT_FALSE(Recovery(*env).recovering());
  EXPECT_GT(std::abs(character::WrapAngle(env->heading() - heading_before)), 1.0);
  EXPECT_NEAR(Steering(*env).desired_heading(), env->heading(), 1e-9);
  EXPECT_NEAR(Steering(*env).HeadingError(*env), 0.0, 1e-9);
  env->ReferenceState(env->time(), qpos.data(), qvel.data());
  const character::Quat reference = {qpos[3], qpos[4], qpos[5], qpos[6]};
  const character::Quat character = {env->data().qpos[3], env->data().qpos[4], env->data().qpos[5],
                                     env->data().qpos[6]};
  EXPECT_NEAR(character::WrapAngle(character::YawOf(reference) - character::YawOf(character)), 0.0,
              0.15);
}

// A get-up ends standing: told to walk, it hands back through the set's stand-to-walk transition
// (the walk's clip may be mid-stride); told to stand, to the stand itself.
TEST_F(RecoveryEnvTest, AGetUpHandsBackThroughTheTransitionFromStanding) {
  SteerStandWalkAndStart();
  config_.recovery.start_getting_up = 1;
  for (const std::string command : {"walk", "stand"}) {
    SCOPED_TRACE(command);
    auto env = Make(3);
    std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
    env->Reset(obs.data());
    ASSERT_TRUE(Recovery(*env).recovering());
    Steering(*env).SetCommand(*env, env->motion_set().Find(command));
    std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
    for (int steps = 0; Recovery(*env).recovering() && steps < 200; ++steps) {
      env->ReferenceState(env->time(), qpos.data(), qvel.data());  // the get-up played as shown
      env->SetState(qpos.data(), qvel.data());
      ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated);
    }
    ASSERT_FALSE(Recovery(*env).recovering());
    EXPECT_EQ(env->motion_set().entry(env->reference_entry()).name,
              command == "walk" ? "walk_start" : "stand");
  }
}

// With `stand_after_get_up`, a character told to walk stands that long after its get-up before the
// walk leads (through the set's transition); meanwhile it is told to stand, and scored against
// the walk it was told.
TEST_F(RecoveryEnvTest, AfterAGetUpTheCharacterStandsBeforeTheCommandLeads) {
  SteerStandWalkAndStart();
  config_.recovery.start_getting_up = 1;
  config_.recovery.stand_after_get_up = 0.5;
  auto env = Make(3);
  const int base = ObservationSize(*character_);
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->Reset(obs.data());
  ASSERT_TRUE(Recovery(*env).recovering());
  const int walk = env->motion_set().Find("walk"), stand = env->motion_set().Find("stand");
  Steering(*env).SetCommand(*env, walk);
  std::vector<double> qpos(character_->model()->nq), qvel(character_->model()->nv);
  auto step = [&] {
    env->ReferenceState(env->time(), qpos.data(), qvel.data());  // played as shown
    env->SetState(qpos.data(), qvel.data());
    ASSERT_FALSE(env->Step(action.data(), obs.data()).terminated);
  };
  for (int steps = 0; Recovery(*env).recovering() && steps < 200; ++steps) step();
  ASSERT_FALSE(Recovery(*env).recovering());
  EXPECT_EQ(env->reference_entry(), stand);
  EXPECT_TRUE(Steering(*env).standing_after_get_up());
  EXPECT_EQ(Steering(*env).command_entry(), walk);
  const Command& standing = env->motion_set().entry(stand).command;
  EXPECT_NEAR(obs[base], standing.forward, 1e-6);
  EXPECT_GT(Steering(*env).SpeedError(), 0.5);  // against the walk: standing is not on command
  int steps = 0;
  while (env->reference_entry() == stand && steps < 100) {
    step();
    ++steps;
  }
  EXPECT_EQ(steps, 15);  // 0.5 s at 30 Hz
  EXPECT_EQ(env->motion_set().entry(env->reference_entry()).name, "walk_start");
  EXPECT_FALSE(Steering(*env).standing_after_get_up());
  EXPECT_NEAR(obs[base], env->motion_set().entry(walk).command.forward, 1e-6);
}

}  // namespace
}  // namespace ragdoll::sim
