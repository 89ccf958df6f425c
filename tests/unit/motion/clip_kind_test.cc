#include "motion/clip_kind.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "character/character.h"
#include "character/motion_io.h"

namespace ragdoll::motion {
namespace {

using character::LoadMotion;
using character::MotionClip;

const std::string kAssets = RAGDOLL_ASSETS_DIR;

MotionClip Shipped(const std::string& name) {
  return LoadMotion(kAssets + "/motions/" + name + ".json");
}

TEST(ClipKind, LoopsAreToldFromTheirEnds) {
  for (const char* name : {"walk", "stand", "squat", "arms", "turn_left", "strafe_left"}) {
    std::string why;
    EXPECT_TRUE(ClosesALoop(Shipped(name), &why)) << name << ": " << why;
  }
  // DeepMimic's captured walk closes its cycle only roughly (7.8 deg on average).
  {
    std::string why;
    EXPECT_TRUE(ClosesALoop(
        LoadMotion(std::string(RAGDOLL_SHARED_DATA_DIR) + "/deepmimic/motions/humanoid3d_walk.txt"),
        &why))
        << why;
  }
  // walk_start ends in the walk's stride, walk_stop in the stand.
  for (const char* name : {"walk_start", "walk_stop"}) {
    std::string why;
    EXPECT_FALSE(ClosesALoop(Shipped(name), &why)) << name;
    EXPECT_FALSE(why.empty()) << name;
    std::printf("%s: %s\n", name, why.c_str());
  }
  const MotionClip start = Shipped("walk_start");
  const MotionClip looped = AsLoop(start);
  EXPECT_TRUE(looped.loop());
  EXPECT_EQ(looped.num_frames(), start.num_frames());
  for (size_t j = 0; j < start.frame(5).joint_rotations.size(); ++j) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(looped.frame(5).joint_rotations[j][k], start.frame(5).joint_rotations[j][k],
                  1e-12);
    }
  }
}

TEST(ClipKind, EachShippedClipGetsItsTemplate) {
  auto character = character::Character::Load(character::DefaultCharacterPath());
  struct Case {
    std::string clip;
    ClipKind kind;
    std::string config;
  };
  const Case cases[] = {
      {"walk", ClipKind::kLocomotion, "walk.yaml"},
      {"walk_backward", ClipKind::kLocomotion, "walk.yaml"},
      {"strafe_left", ClipKind::kLocomotion, "walk.yaml"},
      {"turn_left", ClipKind::kLocomotion, "walk.yaml"},  // turns 90 deg a cycle on the spot
      {"stand", ClipKind::kInPlace, "stand.yaml"},
      {"squat", ClipKind::kInPlace, "stand.yaml"},
      {"arms", ClipKind::kInPlace, "stand.yaml"},
      {"walk_start", ClipKind::kAction, "action.yaml"},
      {"walk_stop", ClipKind::kAction, "action.yaml"},
      {"deepmimic/humanoid3d_getup_facedown", ClipKind::kContactRich, "action.yaml"},
  };
  for (const Case& c : cases) {
    const std::string path =
        kAssets + "/motions/" + c.clip + (c.clip.find("deepmimic") == 0 ? ".txt" : ".json");
    const MotionClip clip = LoadMotion(path);
    const ClipKindChoice choice = ClassifyClip(clip, InspectClip(clip, *character));
    EXPECT_EQ(choice.kind, c.kind) << c.clip << ": " << choice.name << ", " << choice.reason;
    EXPECT_EQ(choice.config, c.config) << c.clip;
    EXPECT_FALSE(choice.reason.empty());
  }
}

}  // namespace
}  // namespace ragdoll::motion
