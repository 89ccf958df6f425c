#include "motion/clip_report.h"

#include <gtest/gtest.h>

#include "character/motion_io.h"
#include "character/skeleton.h"

namespace ragdoll::motion {

using character::AxisAngle;
using character::Character;
using character::FindJoint;
using character::Humanoid3dJoints;
using character::LoadMotion;
using character::MotionClip;
using character::Pose;

namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

class ClipReportTest : public ::testing::Test {
 protected:
  ClipReportTest() : character_(Character::Load(kAssets + "/character/humanoid.xml")) {}

  // The clip with `edit` applied to copies of its frames.
  template <typename F>
  MotionClip Edited(const MotionClip& clip, F edit) {
    std::vector<Pose> frames;
    std::vector<double> durations;
    for (int f = 0; f < clip.num_frames(); ++f) {
      frames.push_back(clip.frame(f));
      durations.push_back(clip.frame_duration(f));
      edit(f, &frames.back());
    }
    return MotionClip(clip.name(), false, durations, frames);
  }

  std::shared_ptr<const Character> character_;
};

TEST_F(ClipReportTest, TheShippedWalkIsPlausible) {
  MotionClip walk = LoadMotion(kAssets + "/motions/walk.json");
  ClipReport r = InspectClip(walk, *character_);
  EXPECT_EQ(r.frames, walk.num_frames());
  EXPECT_TRUE(r.loop);
  EXPECT_EQ(r.joints.size(), Humanoid3dJoints().size());
  EXPECT_GT(r.cycle_displacement[0], 0.5);  // walks forward
  EXPECT_GT(r.root_path_length, 0.5);
  // Each foot is down a little more than half the time (double support), never both in the air.
  EXPECT_GT(r.contact_right, 0.5);
  EXPECT_LT(r.contact_right, 0.9);
  EXPECT_GT(r.contact_left, 0.5);
  EXPECT_LT(r.contact_left, 0.9);
  EXPECT_EQ(r.Count("penetration"), 0) << r.ToText();
  EXPECT_EQ(r.Count("foot_sliding"), 0) << r.ToText();
  EXPECT_EQ(r.Count("joint_limit"), 0) << r.ToText();
  EXPECT_NEAR(r.lowest_point, 0, 0.002);
}

TEST_F(ClipReportTest, FindsPenetrationSlidingAndJointLimits) {
  MotionClip stand = LoadMotion(kAssets + "/motions/stand.json");
  const int knee = FindJoint("left_knee");
  MotionClip bad = Edited(stand, [&](int f, Pose* p) {
    if (f == 10) p->root_position[2] -= 0.05;                           // 5 cm into the floor
    if (f >= 20 && f <= 25) p->root_position[0] += 0.02 * (f - 19);     // 0.6 m/s sliding
    if (f > 25) p->root_position[0] += 0.12;                            // (then stays)
    if (f == 3) p->joint_rotations[knee] = AxisAngle({0, 1, 0}, -0.6);  // hyperextended
  });
  ClipReport r = InspectClip(bad, *character_);
  ASSERT_GE(r.Count("penetration"), 1) << r.ToText();
  for (const auto& i : r.issues) {
    if (i.kind == "penetration") {
      EXPECT_EQ(i.frame, 10) << i.detail;
    }
    if (i.kind == "joint_limit") {
      EXPECT_EQ(i.frame, 3);
      EXPECT_NE(i.detail.find("left_knee"), std::string::npos) << i.detail;
    }
    if (i.kind == "foot_sliding") {
      // The edits: the dropped frame and the one after, the slide, and the knee (which moves
      // that foot).
      EXPECT_TRUE(i.frame == 3 || i.frame == 4 || i.frame == 10 || i.frame == 11 ||
                  (i.frame >= 20 && i.frame <= 26))
          << i.frame;
    }
  }
  EXPECT_EQ(r.Count("joint_limit"), 1) << r.ToText();
  EXPECT_GE(r.Count("foot_sliding"), 10) << r.ToText();  // both feet, frames 20-25
  EXPECT_NE(r.ToText().find("penetration     1 frame"), std::string::npos) << r.ToText();
  EXPECT_NE(r.ToJson().find("\"kind\": \"joint_limit\""), std::string::npos);
}

}  // namespace
}  // namespace ragdoll::motion
