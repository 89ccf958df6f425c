#include "sim/perturbations.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "character/motion_io.h"
#include "common/config_section.h"
#include "sim/imitation_env.h"
#include "tests/unit/sim/turned_clip.h"

namespace ragdoll::sim {
namespace {

using ::testing::HasSubstr;

const std::string kAssets = RAGDOLL_ASSETS_DIR;
constexpr double kDt = 1.0 / 30;

class PerturbationsTest : public ::testing::Test {
 protected:
  PerturbationsTest()
      : character_(character::Character::Load(kAssets + "/character/humanoid.xml", kDt / 10)),
        data_(character_->MakeData()) {
    config_.bodies = {"chest"};
    config_.interval_min = config_.interval_max = 1.0;  // 30 steps
    config_.duration_min = config_.duration_max = 0.1;  // 3 steps
    config_.start = 20;
    config_.max = 30;
    config_.step = 5;
    config_.window = 2;
    config_.judge = 0.5;  // 15 steps
  }
  // The horizontal force on the chest now, N.
  double Force() const {
    const double* f =
        data_->xfrc_applied + 6 * mj_name2id(character_->model(), mjOBJ_BODY, "chest");
    EXPECT_EQ(f[2], 0);
    return std::hypot(f[0], f[1]);
  }
  // An environment on the character with the PD targets as actions, 3-s episodes, no pushes.
  static EnvConfig Env() {
    EnvConfig env;
    env.character = kAssets + "/character/humanoid.xml";
    env.substeps = 10;
    env.action_mode = ActionMode::kOffset;
    env.max_episode_steps = 90;
    return env;
  }
  // The quarter (Perturbations::Quarter) an angle from forward lies in: pi/2 wide around forward
  // (0), left, backward and right.
  static int QuarterOf(double angle) {
    const double a = std::remainder(angle, 2 * M_PI);
    return static_cast<int>(std::lround(a / (M_PI / 2)) + 4) % 4;
  }
  std::shared_ptr<const character::Character> character_;
  character::DataPtr data_;
  PerturbationConfig config_;
};

// Every 30 steps a push of 3 steps whose impulse is in [level / 2, level]; nothing in between.
TEST_F(PerturbationsTest, PushesForTheirDurationAtTheirIntervalWithinTheLevel) {
  Perturbations p(config_, *character_, kDt, 7);
  std::vector<int> pushed_steps;
  for (int step = 1; step <= 95; ++step) {
    p.BeforeStep(data_.get());
    const double force = Force();
    if (force > 0) {
      pushed_steps.push_back(step);
      const double impulse = force * 3 * kDt;
      EXPECT_GE(impulse, 10 - 1e-9);
      EXPECT_LE(impulse, 20 + 1e-9);
    }
    p.AfterStep(false);
  }
  EXPECT_EQ(pushed_steps, (std::vector<int>{30, 31, 32, 63, 64, 65}));
  EXPECT_EQ(p.pushes(), 2);
}

// A push that falls due while the character gets up waits until it stands.
TEST_F(PerturbationsTest, APushWaitsWhileTheCharacterGetsUp) {
  Perturbations p(config_, *character_, kDt, 7);
  std::vector<int> pushed_steps;
  for (int step = 1; step <= 45; ++step) {
    p.BeforeStep(data_.get(), /*may_push=*/step < 20 || step >= 40);
    if (Force() > 0) pushed_steps.push_back(step);
    p.AfterStep(false);
  }
  EXPECT_EQ(pushed_steps, (std::vector<int>{40, 41, 42}));
  EXPECT_EQ(p.pushes(), 1);
}

// The level rises by a step after a window of survived pushes, up to max, and falls by a step
// after a window of falls, down to start; an episode that ends in a fall judges its push.
TEST_F(PerturbationsTest, TheLevelFollowsTheCharacterWithinStartAndMax) {
  config_.interval_min = config_.interval_max = 0.1;  // a push every 6 steps
  Perturbations p(config_, *character_, kDt, 7);
  // Steps until the next push starts; that step ends the episode in a fall, or not.
  auto push_and_wait = [&](bool fall) {
    for (int before = p.pushes(); p.pushes() == before;) {
      p.BeforeStep(data_.get());
      if (p.pushes() == before) p.AfterStep(false);
    }
    p.AfterStep(fall);
    if (fall) p.Reset();
  };
  EXPECT_EQ(p.level(), 20);
  // Each push is judged survived when the next one comes first.
  for (int i = 0; i < 3; ++i) push_and_wait(false);
  EXPECT_EQ(p.level(), 25);
  for (int i = 0; i < 3; ++i) push_and_wait(false);
  EXPECT_EQ(p.level(), 30);  // and held at max
  for (int i = 0; i < 2; ++i) push_and_wait(true);
  EXPECT_EQ(p.level(), 25);
  for (int i = 0; i < 6; ++i) push_and_wait(true);
  EXPECT_EQ(p.level(), 20);  // held at start
}

// Per situation: pushes toward the character's back (its heading turned by pi) that always
// topple it keep their level at start and come to be drawn most of the time; the other
// quarters rise to max, and the situations of a character told to stand still keep their own.
TEST_F(PerturbationsTest, PerSituationTheHardQuarterKeepsItsLevelAndIsDrawnMoreOften) {
  config_.interval_min = config_.interval_max = 0.1;
  config_.per_situation = true;
  Perturbations p(config_, *character_, kDt, 7);
  const PushSituation walking{/*heading=*/0.7, /*still=*/false};
  int drawn[Perturbations::kQuarters] = {}, late_backward = 0;
  for (int push = 0; push < 300; ++push) {
    for (int before = p.pushes(); p.pushes() == before;) {
      p.BeforeStep(data_.get(), true, walking);
      if (p.pushes() == before) p.AfterStep(false);
    }
    const double* f =
        data_->xfrc_applied + 6 * mj_name2id(character_->model(), mjOBJ_BODY, "chest");
    const double impulse = std::hypot(f[0], f[1]) * 3 * kDt;
    const int quarter = QuarterOf(std::atan2(f[1], f[0]) - walking.heading);
    ++drawn[quarter];
    const bool backward = quarter == Perturbations::kBackward;
    if (push >= 200) late_backward += backward ? 1 : 0;
    const double level = p.level(0, static_cast<Perturbations::Quarter>(quarter), false);
    EXPECT_GE(impulse, level / 2 - 1e-9);
    EXPECT_LE(impulse, level + 1e-9);
    p.AfterStep(backward);
    if (backward) p.Reset();
  }
  for (int q = 0; q < Perturbations::kQuarters; ++q) EXPECT_GT(drawn[q], 0) << q;
  EXPECT_EQ(p.level(0, Perturbations::kBackward, false), 20);
  EXPECT_GT(p.fall_share(0, Perturbations::kBackward, false), 0.99);
  for (auto q : {Perturbations::kForward, Perturbations::kLeft, Perturbations::kRight}) {
    EXPECT_EQ(p.level(0, q, false), 30) << q;
    EXPECT_LT(p.fall_share(0, q, false), 0.1) << q;  // from 0.5, by about 0.9 a push
  }
  // Weights 1.05 against 3 x (0.05 + a share still settling): about 4 in 5, uniform 1 in 4.
  EXPECT_GT(late_backward, 70);
  EXPECT_EQ(p.level(0, Perturbations::kForward, true), 20);
  EXPECT_EQ(p.fall_share(0, Perturbations::kForward, true), 0.5);
  EXPECT_DOUBLE_EQ(p.level(), (3 * 30 + 5 * 20) / 8.0);
}

TEST_F(PerturbationsTest, AnUnknownBodyIsNamed) {
  config_.bodies = {"tail"};
  try {
    Perturbations p(config_, *character_, kDt, 1);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'tail'"));
  }
}

// In the environment: pushes leave the start phases and the first observation as they were, add
// the level as an episode figure, and a character standing by PD tracking falls sooner when
// pushed hard on the chest.
TEST_F(PerturbationsTest, AnEnvironmentWithPushesStartsItsEpisodesAsBeforeAndFallsSooner) {
  EnvConfig env = Env();
  auto clip = std::make_shared<const character::MotionClip>(
      character::LoadMotion(kAssets + "/motions/stand.json"));
  ImitationEnv plain(character_, clip, env, 5);
  config_.start = config_.max = 150;
  env.perturbations = config_;
  ImitationEnv pushed(character_, clip, env, 5);
  EXPECT_EQ(pushed.spec().figure_names.back(), "push_level");
  EXPECT_EQ(pushed.spec().figure_units.back(), "N s");
  EXPECT_EQ(pushed.spec().observation_size, plain.spec().observation_size);
  const int n = plain.spec().observation_size;
  std::vector<float> a(n), b(n), action(plain.spec().action_size, 0.0f);
  int plain_steps = 0, pushed_steps = 0;
  for (int episode = 0; episode < 3; ++episode) {
    plain.Reset(a.data());
    pushed.Reset(b.data());
    EXPECT_EQ(a, b);
    EXPECT_EQ(plain.time(), pushed.time());
    for (StepResult r; !r.terminated && !r.truncated; ++plain_steps)
      r = plain.Step(action.data(), a.data());
    for (StepResult r; !r.terminated && !r.truncated; ++pushed_steps) {
      r = pushed.Step(action.data(), b.data());
    }
    EXPECT_EQ(pushed.episode().figures.back(), 150);
  }
  EXPECT_LT(pushed_steps, plain_steps);
}

// The environment places each push in its situation: the quarter seen from the character's
// heading (a stand clip turned by 1 rad, so a heading of 0 in its place would put most pushes in
// the wrong quarter) and the clip's command (a stand: still; a walk: moving). Each push's judgement
// moves the fall share of that one situation and no other.
TEST_F(PerturbationsTest, TheEnvironmentPlacesEachPushByTheCharactersHeadingAndCommand) {
  EnvConfig env = Env();
  config_.interval_min = config_.interval_max = 0.1;
  config_.per_situation = true;
  env.perturbations = config_;
  const int chest = 0;
  for (const std::string name : {"stand", "walk"}) {
    SCOPED_TRACE(name);
    const bool still = name == "stand";
    auto clip = std::make_shared<const character::MotionClip>(
        TurnedClip(character::LoadMotion(kAssets + "/motions/" + name + ".json"), 1.0, name));
    ImitationEnv e(character_, clip, env, 3);
    const Perturbations& p = *e.perturbations();
    auto shares = [&] {
      std::vector<double> s;
      for (bool st : {false, true}) {
        for (int q = 0; q < Perturbations::kQuarters; ++q)
          s.push_back(p.fall_share(chest, static_cast<Perturbations::Quarter>(q), st));
      }
      return s;
    };
    std::vector<float> obs(e.spec().observation_size), action(e.spec().action_size, 0.0f);
    const int body = mj_name2id(character_->model(), mjOBJ_BODY, "chest");
    // The quarter of the push awaiting its judgement (-1: none), and how many were judged.
    int pending = -1, judged = 0, turned_quarters = 0;
    std::vector<double> before = shares();
    // The situations whose fall share moved since the last look must be among `expected`.
    auto judged_were = [&](std::vector<int> expected) {
      const std::vector<double> after = shares();
      int moved = 0;
      for (size_t i = 0; i < after.size(); ++i) {
        if (after[i] == before[i]) continue;
        ++judged;
        ++moved;
        const int offset = still ? Perturbations::kQuarters : 0;
        bool found = false;
        for (int q : expected) found = found || (q >= 0 && static_cast<int>(i) == offset + q);
        EXPECT_TRUE(found) << "situation " << i << " judged";
      }
      before = after;
      return moved;
    };
    e.Reset(obs.data());
    while (judged < 60) {
      const int pushes = p.pushes();
      const double heading = e.heading();
      const StepResult r = e.Step(action.data(), obs.data());
      if (p.pushes() == pushes) {
        if (judged_were({pending}) > 0) pending = -1;
      } else {
        // A new push judges the one before it, and a fall may judge the new one at once.
        const double* f = e.data().xfrc_applied + 6 * body;
        const double world = std::atan2(f[1], f[0]);
        const int quarter = QuarterOf(world - heading);
        if (QuarterOf(world) != quarter) ++turned_quarters;
        const int moved = judged_were({pending, quarter});
        pending = moved > (pending >= 0 ? 1 : 0) ? -1 : quarter;
      }
      if (r.terminated || r.truncated) {
        e.Reset(obs.data());  // judges a push still pending as survived
        judged_were({pending});
        pending = -1;
      }
    }
    // Turned by 1 rad, about 0.64 of the pushes lie in another quarter of the world than of the
    // character (those within 0.36 of a quarter's width of its clockwise edge stay).
    EXPECT_GT(turned_quarters, 0.45 * p.pushes());
  }
}

TEST(PerturbationConfig, ReadsItsSectionAndNamesBadValues) {
  auto read = [](const std::string& yaml) {
    return ReadEnvConfig(ConfigSection::FromString("motion: m.json\n" + yaml, "env.yaml"),
                         "humanoid.xml");
  };
  EXPECT_FALSE(read("").perturbations.enabled());
  const EnvConfig c = read(
      "perturbations:\n  interval: {min: 2, max: 4}\n  impulse: {start: 10, max: 90, step: 2}\n"
      "  curriculum: {window: 20}\n");
  EXPECT_EQ(c.perturbations.bodies,
            (std::vector<std::string>{"root", "chest", "left_shoulder", "right_shoulder"}));
  EXPECT_EQ(c.perturbations.interval_min, 2);
  EXPECT_EQ(c.perturbations.interval_max, 4);
  EXPECT_EQ(c.perturbations.max, 90);
  EXPECT_EQ(c.perturbations.window, 20);
  EXPECT_EQ(c.perturbations.duration_max, 0.2);
  EXPECT_FALSE(c.perturbations.per_situation);
  EXPECT_TRUE(
      read("perturbations:\n  curriculum: {per_situation: true}\n").perturbations.per_situation);
  auto error = [&](const std::string& yaml) -> std::string {
    try {
      read(yaml);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_THAT(error("perturbations:\n  impulse: {start: 50, max: 40}\n"),
              HasSubstr("perturbations.impulse.max"));
  EXPECT_THAT(error("perturbations:\n  interval: {min: 0}\n"),
              HasSubstr("perturbations.interval.min"));
  EXPECT_THAT(error("perturbations:\n  bodies: []\n"), HasSubstr("perturbations.bodies"));
  EXPECT_THAT(error("perturbations:\n  curriculum: {raise_above: 0.4, lower_below: 0.6}\n"),
              HasSubstr("lower_below"));
  EXPECT_THAT(error("perturbations:\n  impluse: {start: 5}\n"), HasSubstr("impluse"));
}

}  // namespace
}  // namespace ragdoll::sim
