#include "motion/foot_cleanup.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "character/motion_io.h"
#include "character/skeleton.h"
#include "motion/clip_report.h"

namespace ragdoll::motion {

using character::Character;
using character::DataPtr;
using character::FindJoint;
using character::LoadMotion;
using character::MotionClip;
using character::Pose;
using character::Vec3;

namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

class FootCleanupTest : public ::testing::Test {
 protected:
  FootCleanupTest()
      : character_(Character::Load(kAssets + "/character/humanoid.xml")),
        walk_(LoadMotion(kAssets + "/motions/walk.json")) {}

  // The shipped walk as a retarget with the wrong proportions leaves it: the pelvis 3 cm too
  // high (the feet float) and travelling 12 % farther than the legs step (the feet slide).
  MotionClip Distorted() const {
    std::vector<Pose> frames;
    std::vector<double> durations;
    const Vec3 start = walk_.frame(0).root_position;
    for (int f = 0; f < walk_.num_frames(); ++f) {
      Pose p = walk_.frame(f);
      for (int i = 0; i < 2; ++i) {
        p.root_position[i] = start[i] + 1.12 * (p.root_position[i] - start[i]);
      }
      p.root_position[2] += 0.03;
      frames.push_back(p);
      durations.push_back(walk_.frame_duration(f));
    }
    return MotionClip("distorted", true, durations, frames);
  }

  std::shared_ptr<const Character> character_;
  MotionClip walk_;
};

TEST_F(FootCleanupTest, PutsFloatingSlidingFeetOnTheFloorAndHoldsThemStill) {
  const MotionClip bad = Distorted();
  const ClipReport before = InspectClip(bad, *character_);
  // The distortion is what the clean-up is for: no foot within 2 cm of the floor, and the
  // planted feet drift 12 % of a stride.
  EXPECT_EQ(before.contact_right, 0);
  EXPECT_EQ(before.contact_left, 0);

  FootCleanupReport report;
  const MotionClip fixed = FixFeet(bad, *character_, FootCleanupOptions{}, &report);
  const ClipReport after = InspectClip(fixed, *character_);
  EXPECT_GE(report.plants[0], 1);
  EXPECT_GE(report.plants[1], 1);
  EXPECT_NEAR(report.float_height[0], 0.03, 0.005);
  EXPECT_NEAR(report.float_height[1], 0.03, 0.005);
  EXPECT_EQ(report.missed_frames, 0);
  // Both feet alternate on the floor, none sinks, slides or bends past a limit.
  EXPECT_GE(after.contact_right, 0.4);
  EXPECT_GE(after.contact_left, 0.4);
  EXPECT_EQ(after.Count("penetration"), 0);
  EXPECT_EQ(after.Count("foot_sliding"), 0);
  EXPECT_EQ(after.Count("joint_limit"), 0);
  EXPECT_GT(after.lowest_point, -0.005);

  // A planted foot's lowest corner holds still while it stays the lowest (the foot rolls from
  // one corner to the next).
  const mjModel* m = character_->model();
  DataPtr d = character_->MakeData();
  const int geoms[2] = {mj_name2id(m, mjOBJ_GEOM, "right_ankle"),
                        mj_name2id(m, mjOBJ_GEOM, "left_ankle")};
  double worst_slide = 0;
  int planted_steps = 0;
  std::array<double, 24> previous[2];
  int previous_corner[2] = {-1, -1};
  for (int f = 0; f < fixed.num_frames(); ++f) {
    character_->PoseToQpos(fixed.frame(f), d->qpos);
    mj_kinematics(m, d.get());
    for (int s = 0; s < 2; ++s) {
      std::array<double, 24> corners;
      int lowest = 0;
      const double* p = d->geom_xpos + 3 * geoms[s];
      const double* r = d->geom_xmat + 9 * geoms[s];
      const double* size = m->geom_size + 3 * geoms[s];
      for (int c = 0; c < 8; ++c) {
        const double local[3] = {(c & 1 ? 1 : -1) * size[0], (c & 2 ? 1 : -1) * size[1],
                                 (c & 4 ? 1 : -1) * size[2]};
        for (int i = 0; i < 3; ++i) {
          corners[3 * c + i] =
              p[i] + r[3 * i] * local[0] + r[3 * i + 1] * local[1] + r[3 * i + 2] * local[2];
        }
        if (corners[3 * c + 2] < corners[3 * lowest + 2]) lowest = c;
      }
      const bool planted = corners[3 * lowest + 2] < 1e-4;
      if (planted && previous_corner[s] == lowest) {
        worst_slide = std::max(worst_slide,
                               std::hypot(corners[3 * lowest] - previous[s][3 * lowest],
                                          corners[3 * lowest + 1] - previous[s][3 * lowest + 1]));
        ++planted_steps;
      }
      previous[s] = corners;
      previous_corner[s] = planted ? lowest : -1;
    }
  }
  EXPECT_GT(planted_steps, fixed.num_frames() / 2);
  EXPECT_LT(worst_slide, 1e-3);

  // Above the legs, nothing changed; the pelvis only came down.
  for (int f = 0; f < fixed.num_frames(); ++f) {
    const Pose &a = bad.frame(f), &b = fixed.frame(f);
    EXPECT_EQ(a.root_position[0], b.root_position[0]);
    EXPECT_EQ(a.root_position[1], b.root_position[1]);
    EXPECT_LE(b.root_position[2], a.root_position[2]);
    EXPECT_GE(b.root_position[2], a.root_position[2] - report.max_drop - 1e-12);
    EXPECT_EQ(a.root_rotation, b.root_rotation);
    for (const char* joint : {"chest", "neck", "right_shoulder", "left_elbow"}) {
      EXPECT_EQ(a.joint_rotations[FindJoint(joint)], b.joint_rotations[FindJoint(joint)]) << joint;
    }
  }
}

TEST_F(FootCleanupTest, LeavesACleanClipAlmostAsItWas) {
  FootCleanupReport report;
  const MotionClip fixed = FixFeet(walk_, *character_, FootCleanupOptions{}, &report);
  EXPECT_GE(report.plants[0], 1);
  EXPECT_GE(report.plants[1], 1);
  // The shipped walk's feet are within a few millimetres of planted already; the pelvis comes
  // down a little where a straight leg must reach those millimetres farther.
  EXPECT_LT(report.max_correction, 0.01);
  EXPECT_LT(report.max_drop, 0.01) << report.max_correction;
  const ClipReport after = InspectClip(fixed, *character_);
  EXPECT_EQ(after.Count("foot_sliding"), 0);
  EXPECT_EQ(after.Count("penetration"), 0);
}

TEST_F(FootCleanupTest, RefusesThresholdsThatAreNotPositive) {
  FootCleanupOptions o;
  o.blend = 0;
  EXPECT_THROW(FixFeet(walk_, *character_, o), std::invalid_argument);
  o = FootCleanupOptions{};
  o.plant_speed = std::nan("");
  EXPECT_THROW(FixFeet(walk_, *character_, o), std::invalid_argument);
}

}  // namespace
}  // namespace ragdoll::motion
