#include "sim/imitation_env.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "character/ground_contacts.h"
#include "character/motion_io.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

// A clip that holds the model's rest pose (all joints at zero, soles on the floor), so that
// expected values follow from the model's dimensions alone.
std::shared_ptr<const character::MotionClip> RestClip(bool loop, double duration) {
  character::Pose rest;
  rest.root_position = {0, 0, 0.8814};
  rest.joint_rotations.assign(12, character::kIdentityQuat);
  return std::make_shared<const character::MotionClip>("rest", loop,
                                                       std::vector<double>{duration, duration},
                                                       std::vector<character::Pose>{rest, rest});
}

class ImitationEnvTest : public ::testing::Test {
 protected:
  ImitationEnvTest() {
    config_.character = kAssets + "/character/humanoid.xml";
    config_.motion = kAssets + "/motions/walk.json";
  }
  std::unique_ptr<ImitationEnv> Make(std::shared_ptr<const character::MotionClip> clip,
                                     uint64_t seed = 1) {
    auto character = character::Character::Load(config_.character, config_.physics_dt());
    return std::make_unique<ImitationEnv>(character, clip, config_, seed);
  }
  std::shared_ptr<const character::MotionClip> Walk() {
    return std::make_shared<const character::MotionClip>(character::LoadMotion(config_.motion));
  }
  EnvConfig config_;
};

TEST_F(ImitationEnvTest, SpecReportsSizesAndNames) {
  auto env = Make(Walk());
  const EnvSpec& spec = env->spec();
  // root 1 + 6 + 3 + 3, 14 bodies x (3 + 6 + 3 + 3), phase 3
  EXPECT_EQ(spec.observation_size, 13 + 14 * 15 + 3);
  EXPECT_EQ(spec.observation_names.size(), static_cast<size_t>(spec.observation_size));
  EXPECT_EQ(spec.action_size, 28);
  EXPECT_EQ(spec.action_names.front(), "chest_y");
  EXPECT_EQ(spec.action_names.back(), "left_elbow");
  EXPECT_EQ(spec.observation_names.front(), "root.height");
  EXPECT_EQ(spec.observation_names.back(), "phase.cos");
  EXPECT_DOUBLE_EQ(spec.control_dt, 1.0 / 30);
  EXPECT_DOUBLE_EQ(spec.max_reward_per_step, 1.0);
}

TEST_F(ImitationEnvTest, ResetPlacesTheReferenceStateAndObservesIt) {
  config_.random_start = false;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size);
  env->ResetAtPhase(0.25, obs.data());
  EXPECT_NEAR(obs[0], 0.8814, 1e-6);  // root height
  EXPECT_NEAR(obs[1], 1.0, 1e-6);     // root rotation column x = (1, 0, 0)
  EXPECT_NEAR(obs[5], 1.0, 1e-6);     // root rotation column y = (0, 1, 0)
  // Chest: 0.236151 m above the root, in the heading frame.
  EXPECT_NEAR(obs[13 + 2], 0.236151, 1e-6);
  size_t n = obs.size();
  EXPECT_NEAR(obs[n - 3], 0.25, 1e-6);
  EXPECT_NEAR(obs[n - 2], 1.0, 1e-6);  // sin(pi/2)
  EXPECT_NEAR(obs[n - 1], 0.0, 1e-6);
  // Walking clip: the reference velocity is the clip's forward speed (0.9 m/s).
  auto walk = Make(Walk());
  walk->ResetAtPhase(0.3, obs.data());
  EXPECT_NEAR(walk->data().qvel[0], 0.9, 1e-6);
  EXPECT_NEAR(obs[7], 0.9, 1e-3);  // root.vel.x in the heading frame
}

TEST_F(ImitationEnvTest, EveryTermIsOneOnTheReference) {
  auto env = Make(Walk());
  std::vector<float> obs(env->spec().observation_size);
  for (double phase : {0.0, 0.37, 0.81}) {
    env->ResetAtPhase(phase, obs.data());
    RewardTerms t = env->RewardAt(env->time());
    EXPECT_DOUBLE_EQ(t.rotation, 1.0);
    EXPECT_DOUBLE_EQ(t.velocity, 1.0);
    EXPECT_DOUBLE_EQ(t.end_effector, 1.0);
    EXPECT_DOUBLE_EQ(t.com, 1.0);
    EXPECT_DOUBLE_EQ(t.root, 1.0);
    EXPECT_DOUBLE_EQ(t.total, 1.0);
  }
}

TEST_F(ImitationEnvTest, KnownKneePerturbationGivesHandComputedReward) {
  config_.random_start = false;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size);
  env->ResetAtPhase(0, obs.data());
  const mjModel* m = env->character().model();
  std::vector<double> qpos(env->data().qpos, env->data().qpos + m->nq);
  std::vector<double> qvel(env->data().qvel, env->data().qvel + m->nv);
  const double theta = 0.2;
  qpos[env->character().joints()[3].qpos_address] += theta;  // right knee
  env->SetState(qpos.data(), qvel.data());
  RewardTerms t = env->RewardAt(env->time());

  // Rotation: the knee weighs 0.3 of the 3.8 total joint weight: err = 0.3 / 3.8 * 0.2^2.
  double rotation_err = 0.3 / 3.8 * theta * theta;
  EXPECT_NEAR(t.rotation, std::exp(-2.0 * rotation_err), 1e-12);
  EXPECT_DOUBLE_EQ(t.velocity, 1.0);
  EXPECT_DOUBLE_EQ(t.root, 1.0);
  // End effectors: the right ankle swings on a 0.40987 m radius about the knee; the chord is
  // 2 r sin(theta / 2); the mean over four end effectors of the squared offsets.
  double chord = 2 * 0.40987 * std::sin(theta / 2);
  EXPECT_NEAR(t.end_effector, std::exp(-10.0 * chord * chord / 4), 1e-9);
  // Centre of mass: the shank (2.742 kg, centre 0.2 m below the knee) and the foot (0.798 kg,
  // centre (0.045, 0, -0.40987 - 0.0225) from the knee) turn by theta about the knee's y axis,
  // which maps (x, z) to (x cos + z sin, -x sin + z cos).
  auto moved = [theta](double x, double z, double* dx, double* dz) {
    *dx = x * std::cos(theta) + z * std::sin(theta) - x;
    *dz = -x * std::sin(theta) + z * std::cos(theta) - z;
  };
  double sx, sz, fx, fz;
  moved(0, -0.2, &sx, &sz);
  moved(0.045, -0.43237, &fx, &fz);
  double cx = (2.742 * sx + 0.798 * fx) / 60, cz = (2.742 * sz + 0.798 * fz) / 60;
  EXPECT_NEAR(t.com, std::exp(-10.0 * (cx * cx + cz * cz)), 1e-9);
  double total = 0.5 * t.rotation + 0.05 + 0.15 * t.end_effector + 0.1 * t.com + 0.2;
  EXPECT_NEAR(t.total, total, 1e-12);
  EXPECT_LT(t.total, 1.0);
}

TEST_F(ImitationEnvTest, RagdollDroppedOnItsBackTerminates) {
  config_.random_start = false;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
  env->ResetAtPhase(0, obs.data());
  const mjModel* m = env->character().model();
  std::vector<double> qpos(env->data().qpos, env->data().qpos + m->nq);
  std::vector<double> qvel(m->nv, 0.0);
  // Lying face up: turned -90 degrees about y, so the body's +x (its front) points up.
  character::Quat on_back = character::AxisAngle({0, 1, 0}, -M_PI / 2);
  qpos[2] = 0.2;
  std::copy(on_back.begin(), on_back.end(), qpos.begin() + 3);
  env->SetState(qpos.data(), qvel.data());
  StepResult s;
  int steps = 0;
  do {
    env->ReferenceAction(action.data());
    s = env->Step(action.data(), obs.data());
    ++steps;
  } while (!s.terminated && !s.truncated && steps < 30);
  EXPECT_TRUE(s.terminated);
  EXPECT_FALSE(s.truncated);
  EXPECT_EQ(env->episode().end, EpisodeEnd::kFell);
  EXPECT_LE(steps, 10);  // within a third of a second of falling 0.2 m
  EXPECT_TRUE(env->episode().fell());
}

TEST_F(ImitationEnvTest, RootFarFromTheReferenceTerminates) {
  config_.random_start = false;
  config_.max_root_distance = 0.5;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
  env->ResetAtPhase(0, obs.data());
  const mjModel* m = env->character().model();
  std::vector<double> qpos(env->data().qpos, env->data().qpos + m->nq);
  std::vector<double> qvel(env->data().qvel, env->data().qvel + m->nv);
  qpos[0] += 0.6;  // standing, but 0.6 m to the side of the reference
  env->SetState(qpos.data(), qvel.data());
  env->ReferenceAction(action.data());
  StepResult s = env->Step(action.data(), obs.data());
  EXPECT_TRUE(s.terminated);
  EXPECT_EQ(env->episode().end, EpisodeEnd::kStrayed);
}

// At the start of each cycle of a looping clip the reference moves onto the character
// (sync_reference), as DeepMimic does: a character standing 0.3 m beside the reference and turned
// by 0.2 rad is scored against the offset until the cycle ends, and against its own place after.
TEST_F(ImitationEnvTest, ReferenceFollowsTheCharacterAtEachNewCycle) {
  auto yaw = [](const double* q) {
    return std::atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
  };
  for (ReferenceSync sync :
       {ReferenceSync::kNone, ReferenceSync::kPosition, ReferenceSync::kPositionAndHeading}) {
    SCOPED_TRACE(static_cast<int>(sync));
    config_.random_start = false;
    config_.reference_sync = sync;
    auto env = Make(RestClip(true, 1.0));
    std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
    env->ResetAtPhase(0.88, obs.data());  // the 4th control step crosses into the next cycle
    const mjModel* m = env->character().model();
    std::vector<double> qpos(env->data().qpos, env->data().qpos + m->nq);
    std::vector<double> qvel(m->nv, 0.0), ref_qpos(m->nq), ref_qvel(m->nv);
    qpos[0] += 0.3;
    character::Quat turned = character::Multiply(
        character::AxisAngle({0, 0, 1}, 0.2), character::Quat{qpos[3], qpos[4], qpos[5], qpos[6]});
    std::copy(turned.begin(), turned.end(), qpos.begin() + 3);
    env->SetState(qpos.data(), qvel.data());
    double root_before = 0;
    for (int i = 1; i <= 5; ++i) {
      env->ReferenceAction(action.data());
      StepResult s = env->Step(action.data(), obs.data());
      ASSERT_FALSE(s.terminated) << i;
      env->ReferenceState(env->time(), ref_qpos.data(), ref_qvel.data());
      const double* root = env->data().qpos;
      const double dx = root[0] - ref_qpos[0], dy = root[1] - ref_qpos[1];
      const double dyaw = yaw(root + 3) - yaw(ref_qpos.data() + 3);
      if (i <= 3 || sync == ReferenceSync::kNone) {  // steps 1-3 end before t = 1
        EXPECT_NEAR(dx, 0.3, 0.02) << i;
        EXPECT_NEAR(dyaw, 0.2, 0.02) << i;
        root_before = s.terms.root;
      } else {  // step 4 ends at t = 1.013, in the new cycle; step 5 within it
        EXPECT_NEAR(dx, 0, i == 4 ? 1e-9 : 0.01) << i;
        EXPECT_NEAR(dy, 0, i == 4 ? 1e-9 : 0.01) << i;
        if (sync == ReferenceSync::kPositionAndHeading) {
          EXPECT_NEAR(dyaw, 0, i == 4 ? 1e-9 : 0.01) << i;
        } else {
          EXPECT_NEAR(dyaw, 0.2, 0.02) << i;
        }
        EXPECT_GT(s.terms.root, root_before + 0.2) << i;  // exp(-5 * 0.09) = 0.64 before
      }
    }
    // A reset puts the reference back on the clip's own path.
    env->ResetAtPhase(0.5, obs.data());
    env->ReferenceState(env->time(), ref_qpos.data(), ref_qvel.data());
    EXPECT_EQ(ref_qpos[0], 0);
    EXPECT_EQ(env->data().qpos[0], 0);
  }
}

TEST_F(ImitationEnvTest, TimeLimitTruncates) {
  config_.random_start = false;
  config_.max_episode_steps = 5;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
  env->Reset(obs.data());
  double total = 0;
  for (int i = 1; i <= 5; ++i) {
    env->ReferenceAction(action.data());
    StepResult s = env->Step(action.data(), obs.data());
    total += s.reward;
    EXPECT_FALSE(s.terminated) << i;
    EXPECT_EQ(s.truncated, i == 5) << i;
  }
  EXPECT_EQ(env->episode().end, EpisodeEnd::kTimeLimit);
  EXPECT_EQ(env->episode().length, 5);
  EXPECT_NEAR(env->episode().episode_return, total, 1e-12);
  EXPECT_NEAR(env->episode().normalized_return, total / 5, 1e-12);
  EXPECT_GT(env->episode().normalized_return, 0.9);  // PD tracking holds the pose for 5 steps
}

TEST_F(ImitationEnvTest, ClipThatDoesNotLoopTruncatesAtItsEnd) {
  config_.random_start = false;
  auto env = Make(RestClip(false, 0.2));  // 0.2 s = 6 control steps at 30 Hz
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
  env->ResetAtPhase(0, obs.data());
  EXPECT_EQ(env->episode().max_length, 6);
  StepResult s;
  int steps = 0;
  do {
    env->ReferenceAction(action.data());
    s = env->Step(action.data(), obs.data());
    ++steps;
  } while (!s.terminated && !s.truncated);
  EXPECT_EQ(steps, 6);
  EXPECT_TRUE(s.truncated);
  EXPECT_EQ(env->episode().end, EpisodeEnd::kClipEnd);
}

TEST_F(ImitationEnvTest, ActionsMapOntoJointRanges) {
  config_.random_start = false;
  auto env = Make(RestClip(true, 1.0));
  std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size, 0.0f);
  env->ResetAtPhase(0, obs.data());
  const auto& hinges = env->character().hinges();
  action[0] = -1;             // chest_y -> lower limit
  action[1] = 1;              // chest_x -> upper limit
  action[2] = 5;              // clipped to 1
  action[3] = std::nanf("");  // counted, treated as 0 -> middle of the range
  env->Step(action.data(), obs.data());
  const double* ctrl = env->data().ctrl;
  EXPECT_DOUBLE_EQ(ctrl[0], hinges[0].lower);
  EXPECT_DOUBLE_EQ(ctrl[1], hinges[1].upper);
  EXPECT_DOUBLE_EQ(ctrl[2], hinges[2].upper);
  EXPECT_NEAR(ctrl[3], 0.5 * (hinges[3].lower + hinges[3].upper), 1e-12);
  EXPECT_EQ(env->bad_actions(), 1);

  // Offset mode: zero action targets the reference pose; one full unit moves offset_scale of
  // the half range.
  config_.action_mode = ActionMode::kOffset;
  config_.offset_scale = 0.5;
  auto offset_env = Make(Walk());
  offset_env->ResetAtPhase(0.2, obs.data());
  std::vector<double> ref_qpos(env->character().model()->nq),
      ref_qvel(env->character().model()->nv);
  offset_env->ReferenceState(offset_env->time() + 1.0 / 30, ref_qpos.data(), ref_qvel.data());
  std::fill(action.begin(), action.end(), 0.0f);
  action[9] = 1;  // right knee
  offset_env->Step(action.data(), obs.data());
  const character::ActuatedHinge& knee = hinges[9];
  ASSERT_EQ(knee.name, "right_knee");
  EXPECT_NEAR(offset_env->data().ctrl[0], ref_qpos[hinges[0].qpos_address], 1e-12);
  EXPECT_NEAR(
      offset_env->data().ctrl[9],
      std::min(knee.upper, ref_qpos[knee.qpos_address] + 0.5 * 0.5 * (knee.upper - knee.lower)),
      1e-12);
}

// Same seed, same actions: bit-identical observations and rewards. Another seed starts
// elsewhere.
TEST_F(ImitationEnvTest, SameSeedGivesBitIdenticalRollouts) {
  auto run = [this](uint64_t seed) {
    auto env = Make(Walk(), seed);
    std::vector<float> obs(env->spec().observation_size), action(env->spec().action_size);
    std::vector<float> trace;
    std::mt19937 actions(1234);
    std::uniform_real_distribution<float> uniform(-1, 1);
    env->Reset(obs.data());
    trace.insert(trace.end(), obs.begin(), obs.end());
    for (int i = 0; i < 150; ++i) {
      for (float& a : action) a = uniform(actions);
      StepResult s = env->Step(action.data(), obs.data());
      trace.insert(trace.end(), obs.begin(), obs.end());
      trace.push_back(static_cast<float>(s.reward));
      trace.push_back(s.terminated ? 1.0f : 0.0f);
      if (s.terminated || s.truncated) env->Reset(obs.data());
    }
    return trace;
  };
  std::vector<float> a = run(42), b = run(42), c = run(43);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0);
  EXPECT_NE(a[0] == c[0] && std::memcmp(a.data(), c.data(), 200 * sizeof(float)) == 0, true);
}

TEST_F(ImitationEnvTest, RejectsNamesTheCharacterLacks) {
  config_.contacts_from_clip = false;
  config_.allowed_contacts = {"right_ankle", "tail"};
  EXPECT_THROW(Make(Walk()), std::exception);
}

// --- contacts from the clip (`allowed_contacts: auto`) ---

// On hands and knees, rocking forward and back: the trunk facing +x, raised at the front by
// asin((arm - thigh) / trunk) = asin((0.574 - 0.47) / 0.48) = 0.22 rad so that hands and knees
// both reach the floor, thighs and arms vertical, knees bent past 90 degrees so that the shins
// rise behind and the feet stay in the air. Placed with its lowest point on the floor.
std::shared_ptr<const character::MotionClip> CrawlClip(const character::Character& character) {
  std::vector<character::Pose> frames;
  for (double rock : {0.0, 0.12, 0.0, -0.12, 0.0}) {
    character::Pose p;
    const double pitch = M_PI / 2 - 0.22;
    p.root_rotation = character::AxisAngle({0, 1, 0}, pitch);
    p.joint_rotations.assign(12, character::kIdentityQuat);
    for (int hip : {2, 7}) p.joint_rotations[hip] = character::AxisAngle({0, 1, 0}, -pitch + rock);
    for (int knee : {3, 8}) p.joint_rotations[knee] = character::AxisAngle({0, 1, 0}, 2.0);
    for (int shoulder : {5, 10})
      p.joint_rotations[shoulder] = character::AxisAngle({0, 1, 0}, -pitch - rock);
    p.joint_rotations[1] = character::AxisAngle({0, 1, 0}, -0.6);  // head up, looking ahead
    p.root_position = {0, 0, 0};
    p.root_position[2] = -character.LowestPoint(p);
    frames.push_back(p);
  }
  return std::make_shared<const character::MotionClip>("crawl", true, std::vector<double>(5, 0.5),
                                                       frames);
}

TEST_F(ImitationEnvTest, AutoContactsAreTheBodiesTheClipPutsOnTheFloor) {
  auto character = character::Character::Load(config_.character, config_.physics_dt());
  auto crawl = CrawlClip(*character);
  // Hands and knees from the clip; the feet, in the air here, are always allowed.
  EXPECT_EQ(character::ClipGroundContacts(*crawl, *character),
            (std::vector<std::string>{"right_knee", "right_ankle", "right_wrist", "left_knee",
                                      "left_ankle", "left_wrist"}));
  const auto contacts = character::GroundContactFractions(*crawl, *character);
  ASSERT_EQ(contacts.size(), 4u);
  EXPECT_EQ(contacts[0].first, "right_knee");
  EXPECT_EQ(contacts[0].second, 1.0);  // every frame
  // The walk puts only its feet down.
  EXPECT_EQ(character::ClipGroundContacts(*Walk(), *character),
            (std::vector<std::string>{"right_ankle", "left_ankle"}));
}

TEST_F(ImitationEnvTest, CrawlRunsUnderAutoContactsAndEndsAtOnceWithFeetOnly) {
  auto character = character::Character::Load(config_.character, config_.physics_dt());
  auto crawl = CrawlClip(*character);
  config_.action_mode = ActionMode::kOffset;
  config_.max_episode_steps = 150;
  // The reference-PD baseline: PD targets on the reference pose, from random phases.
  auto baseline = [&](uint64_t seed) {
    ImitationEnv env(character, crawl, config_, seed);
    std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size);
    double steps = 0;
    const int episodes = 5;
    for (int e = 0; e < episodes; ++e) {
      env.Reset(obs.data());
      for (;;) {
        env.ReferenceAction(action.data());
        StepResult r = env.Step(action.data(), obs.data());
        if (r.terminated || r.truncated) break;
      }
      steps += env.episode().length;
    }
    return steps / episodes;
  };
  double with_auto = baseline(3);
  config_.contacts_from_clip = false;
  config_.allowed_contacts = {"right_ankle", "left_ankle"};
  double feet_only = baseline(3);
  EXPECT_GT(with_auto, 60);  // more than two seconds on hands and knees
  EXPECT_LE(feet_only, 2);
}

TEST_F(ImitationEnvTest, CrawlStillEndsWhenTheHeadHitsTheFloor) {
  auto character = character::Character::Load(config_.character, config_.physics_dt());
  auto crawl = CrawlClip(*character);
  config_.action_mode = ActionMode::kAbsolute;
  config_.random_start = false;
  ImitationEnv env(character, crawl, config_, 1);
  std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size);
  env.Reset(obs.data());
  // The arms swing back off the floor (shoulders driven to full extension) and a push on the head
  // (150 N, down) brings it to the floor, which the crawl never puts there.
  const mjModel* m = character->model();
  const int head = character->BodyId("neck");
  env.SetExternalForce(head, {0, 0, -150});
  StepResult r;
  int steps = 0;
  while (!r.terminated && !r.truncated && steps < 30) {
    env.ReferenceAction(action.data());
    for (size_t i = 0; i < character->hinges().size(); ++i) {
      const std::string& name = character->hinges()[i].name;
      if (name == "right_shoulder_y" || name == "left_shoulder_y") action[i] = 1;
    }
    r = env.Step(action.data(), obs.data());
    ++steps;
  }
  EXPECT_TRUE(r.terminated);
  EXPECT_EQ(env.episode().end, EpisodeEnd::kFell);
  EXPECT_LT(steps, 30);
  // It was the head (the neck body's geometry) that touched.
  const mjData& d = env.data();
  bool head_down = false;
  for (int i = 0; i < d.ncon; ++i) {
    head_down |=
        m->geom_bodyid[d.contact[i].geom1] == head || m->geom_bodyid[d.contact[i].geom2] == head;
  }
  EXPECT_TRUE(head_down);
}

}  // namespace
}  // namespace ragdoll::sim
