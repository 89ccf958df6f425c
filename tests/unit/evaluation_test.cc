#include "actor/evaluation.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "actor/rollout.h"
#include "common/config_section.h"
#include "common/policy.h"

namespace ragdoll::actor {
namespace {

// An untrained policy (outputs near zero: in offset mode, PD tracking of the reference) on the
// stand clip: it stays up for well over a second, and a huge push knocks it over.
class PushTest : public ::testing::Test {
 protected:
  PushTest() {
    env_.motion = std::string(RAGDOLL_ASSETS_DIR) + "/motions/stand.json";
    env_.character = std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
    env_.action_mode = sim::ActionMode::kOffset;
    torch::manual_seed(3);
    RolloutWorker probe(env_, 1, 1, 0, "probe");
    NetworkConfig net;
    net.hidden_units = {32};
    GaussianPolicy policy(probe.spec().observation_size, probe.spec().action_size, net);
    snapshot_ = MakeSnapshot(policy, RunningStats(probe.spec().observation_size), 7, 0);
    push_.settle = 0.2;
    push_.observe = 0.4;
    push_.trials = 6;
    push_.impulses = {0, 400};
  }
  sim::EnvConfig env_;
  v1::PolicySnapshot snapshot_;
  PushConfig push_;
};

TEST_F(PushTest, AHardPushFellsTheCharacterAndNoPushDoesNot) {
  RobustnessResult r = EvaluatePushes(env_, snapshot_, push_, 11);
  ASSERT_EQ(r.results.size(), 2u);
  EXPECT_EQ(r.results[0].fall_rate, 0.0);
  EXPECT_EQ(r.results[1].fall_rate, 1.0);  // 4000 N on the pelvis for 0.1 s
  EXPECT_DOUBLE_EQ(r.results[1].force, 400 / 0.1);
  EXPECT_EQ(r.survived_90, 0.0);
  // The same seed gives the same trials.
  RobustnessResult again = EvaluatePushes(env_, snapshot_, push_, 11);
  EXPECT_EQ(again.results[0].normalized_return, r.results[0].normalized_return);
  EXPECT_EQ(again.results[1].normalized_return, r.results[1].normalized_return);
  EXPECT_NE(r.ToTable().find("largest push survived in >= 90 % of trials: 0.0 N s"),
            std::string::npos)
      << r.ToTable();
  EvaluationResult e;
  EXPECT_NE(e.ToJson(&r).find("\"survived_90\": 0.0"), std::string::npos);
}

TEST_F(PushTest, RejectsUnknownBodiesAndDirections) {
  push_.body = "tail";
  EXPECT_THROW(EvaluatePushes(env_, snapshot_, push_, 1), ConfigError);
  push_.body = "root";
  push_.direction = "up";
  EXPECT_THROW(EvaluatePushes(env_, snapshot_, push_, 1), ConfigError);
}

}  // namespace
}  // namespace ragdoll::actor
