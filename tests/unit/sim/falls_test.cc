#include "sim/falls.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "character/motion_io.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

class FallsTest : public ::testing::Test {
 protected:
  FallsTest()
      : character_(character::Character::Load(kAssets + "/character/humanoid.xml", 1.0 / 300)),
        walk_(character::LoadMotion(kAssets + "/motions/walk.json")) {}
  std::shared_ptr<const character::Character> character_;
  character::MotionClip walk_;
};

// The clip's own frames stand; a settled fall lies still and low, on its front, its back or a
// side, and the same random stream gives the same fall.
TEST_F(FallsTest, ASettledFallLiesStillOnEachSideAndTheClipStands) {
  character::DataPtr d = character_->MakeData();
  character_->PoseToQpos(walk_.Sample(0.3), d->qpos);
  mj_forward(character_->model(), d.get());
  EXPECT_EQ(PostureOf(*character_, *d, 0.7), Posture::kStanding);
  EXPECT_EQ(PostureOf(*character_, *d, 2.0), Posture::kOther);  // upright, but too low

  std::mt19937_64 rng(3);
  std::set<Posture> seen;
  for (int i = 0; i < 16; ++i) {
    const FallenState s = SettledFall(*character_, walk_, rng);
    SCOPED_TRACE(i);
    EXPECT_LT(s.seconds, 4.0);  // came to rest
    for (double v : s.qvel) EXPECT_LT(std::abs(v), 0.3);
    EXPECT_LT(s.qpos[2], 0.4);  // the root near the floor
    EXPECT_NE(s.posture, Posture::kStanding);
    seen.insert(s.posture);
  }
  EXPECT_TRUE(seen.count(Posture::kFaceDown) && seen.count(Posture::kFaceUp) &&
              seen.count(Posture::kSide));
  std::mt19937_64 a(9), b(9);
  EXPECT_EQ(SettledFall(*character_, walk_, a).qpos, SettledFall(*character_, walk_, b).qpos);
}

}  // namespace
}  // namespace ragdoll::sim
