#include "actor/sim/procedural_clips.h"

#include <gtest/gtest.h>

#include <cmath>

#include "actor/sim/motion_io.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

struct FootState {
  double lowest;                   // lowest point of the sole, m
  double x, y;                     // horizontal position of the foot box centre, m
  std::array<mjtNum, 24> corners;  // the box's eight corners, world frame
};

class ProceduralClipsTest : public ::testing::Test {
 protected:
  ProceduralClipsTest()
      : character_(Character::Load(kAssets + "/character/humanoid.xml")),
        clips_(AuthorClips(*character_)),
        data_(character_->MakeData()),
        qpos_(character_->model()->nq) {}

  // Both feet at clip time t.
  std::array<FootState, 2> Feet(const MotionClip& clip, double t) {
    const mjModel* m = character_->model();
    character_->PoseToQpos(clip.Sample(t), qpos_.data());
    std::copy(qpos_.begin(), qpos_.end(), data_->qpos);
    mj_kinematics(m, data_.get());
    std::array<FootState, 2> out;
    const char* names[] = {"right_ankle", "left_ankle"};
    for (int i = 0; i < 2; ++i) {
      int g = mj_name2id(m, mjOBJ_GEOM, names[i]);
      const double* R = data_->geom_xmat + 9 * g;
      const double* size = m->geom_size + 3 * g;
      double reach = std::abs(R[6]) * size[0] + std::abs(R[7]) * size[1] + std::abs(R[8]) * size[2];
      out[i] = {data_->geom_xpos[3 * g + 2] - reach,
                data_->geom_xpos[3 * g],
                data_->geom_xpos[3 * g + 1],
                {}};
      for (int c = 0; c < 8; ++c) {
        double local[3] = {(c & 1 ? 1 : -1) * size[0], (c & 2 ? 1 : -1) * size[1],
                           (c & 4 ? 1 : -1) * size[2]};
        for (int r = 0; r < 3; ++r) {
          out[i].corners[3 * c + r] = data_->geom_xpos[3 * g + r] + R[3 * r] * local[0] +
                                      R[3 * r + 1] * local[1] + R[3 * r + 2] * local[2];
        }
      }
    }
    return out;
  }

  const MotionClip& Clip(const std::string& name) {
    for (const auto& c : clips_) {
      if (c.clip.name() == name) return c.clip;
    }
    throw std::runtime_error("no clip " + name);
  }

  std::shared_ptr<const Character> character_;
  std::vector<AuthoredClip> clips_;
  DataPtr data_;
  std::vector<double> qpos_;
};

TEST_F(ProceduralClipsTest, ShippedFilesMatchTheAuthoringCode) {
  ASSERT_EQ(clips_.size(), 4u);
  for (const auto& authored : clips_) {
    std::string path = kAssets + "/motions/" + authored.clip.name() + ".json";
    MotionClip shipped = LoadMotion(path);
    // Files carry six decimals; regenerate with ragdoll-author-clips after changing the code.
    const MotionClip& code = authored.clip;
    ASSERT_EQ(shipped.num_frames(), code.num_frames()) << path << ": run ragdoll-author-clips";
    EXPECT_EQ(shipped.loop(), code.loop());
    EXPECT_NEAR(shipped.duration(), code.duration(), 1e-12);
    double worst = 0;
    for (int f = 0; f < code.num_frames(); ++f) {
      const Pose &a = shipped.frame(f), &b = code.frame(f);
      for (int k = 0; k < 3; ++k) {
        worst = std::max(worst, std::abs(a.root_position[k] - b.root_position[k]));
      }
      worst = std::max(worst, AngleBetween(a.root_rotation, b.root_rotation));
      for (size_t j = 0; j < a.joint_rotations.size(); ++j) {
        worst = std::max(worst, AngleBetween(a.joint_rotations[j], b.joint_rotations[j]));
      }
    }
    EXPECT_LT(worst, 1e-5) << path << " is out of date: run ragdoll-author-clips";
  }
}

// Feet stay planted and flat on the floor in the clips whose feet do not move.
TEST_F(ProceduralClipsTest, StaticClipsKeepFeetOnTheFloor) {
  for (const char* name : {"stand", "arms", "squat"}) {
    const MotionClip& clip = Clip(name);
    auto start = Feet(clip, 0);
    for (double t = 0; t <= clip.duration(); t += 0.01) {
      auto feet = Feet(clip, t);
      for (int i = 0; i < 2; ++i) {
        EXPECT_NEAR(feet[i].lowest, 0.0, 0.002) << name << " t=" << t;
        EXPECT_NEAR(feet[i].x, start[i].x, 0.002) << name << " t=" << t;
      }
    }
  }
}

TEST_F(ProceduralClipsTest, SquatReachesNinetyDegreesOfKneeFlexion) {
  const MotionClip& squat = Clip("squat");
  Pose deepest = squat.Sample(squat.duration() / 2);
  EXPECT_NEAR(AngleBetween(deepest.joint_rotations[3], kIdentityQuat), 1.55, 1e-6);  // right knee
  EXPECT_LT(deepest.root_position[2], 0.65);
}

// The walk: some foot is always on the floor, no foot sinks, and a foot on the floor does not
// slide: every corner of a foot box that touches the floor (within 5 mm) in two samples 10 ms
// apart stays where it was. (The foot rolls over its toe edge before lifting, so the centre of
// the foot moves while its toe corners stay put.)
TEST_F(ProceduralClipsTest, WalkHasPlantedFeetThatDoNotSlide) {
  const MotionClip& walk = Clip("walk");
  EXPECT_NEAR(walk.cycle_displacement()[0], 0.9, 1e-9);
  const double kPlanted = 0.005;  // sole within 5 mm of the floor
  double max_slide = 0, lowest = 1;
  std::array<FootState, 2> previous = Feet(walk, 0);
  for (double t = 0.01; t <= 2 * walk.duration(); t += 0.01) {
    auto feet = Feet(walk, t);
    EXPECT_LT(std::min(feet[0].lowest, feet[1].lowest), kPlanted)
        << "both feet in the air, t=" << t;
    for (int i = 0; i < 2; ++i) {
      lowest = std::min(lowest, feet[i].lowest);
      for (int c = 0; c < 8; ++c) {
        const mjtNum* now = feet[i].corners.data() + 3 * c;
        const mjtNum* before = previous[i].corners.data() + 3 * c;
        if (now[2] < kPlanted && before[2] < kPlanted) {
          max_slide = std::max(max_slide, std::hypot(now[0] - before[0], now[1] - before[1]));
        }
      }
    }
    previous = feet;
  }
  RecordProperty("walk_lowest_sole_mm", std::to_string(lowest * 1000));
  RecordProperty("walk_max_slide_per_10ms_mm", std::to_string(max_slide * 1000));
  EXPECT_GT(lowest, -0.002);
  EXPECT_LT(max_slide, 0.003);  // under 3 mm per 10 ms at the worst instant
}

}  // namespace
}  // namespace ragdoll::sim
