#include "motion/procedural_clips.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "character/motion_io.h"
#include "character/skeleton.h"

namespace ragdoll::motion {

using character::AngleBetween;
using character::Character;
using character::CharacterJoint;
using character::DataPtr;
using character::DecomposeHinges;
using character::kIdentityQuat;
using character::LoadMotion;
using character::MotionClip;
using character::Pose;
using character::Vec3;
using character::YawOf;

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

  // Samples `clip` every 10 ms from 0 to `end`: some foot is within `planted` of the floor at
  // every sample (a failure otherwise), the lowest sole, and the largest horizontal move of a
  // foot-box corner that is within `planted` of the floor in two consecutive samples.
  void TrackFeet(const MotionClip& clip, double end, double planted, double* lowest,
                 double* max_slide,
                 const std::function<void(const std::array<FootState, 2>&)>& each = {}) {
    std::array<FootState, 2> previous = Feet(clip, 0);
    for (double t = 0.01; t <= end + 1e-9; t += 0.01) {
      auto feet = Feet(clip, t);
      EXPECT_LT(std::min(feet[0].lowest, feet[1].lowest), planted)
          << clip.name() << ": both feet in the air, t=" << t;
      if (each) each(feet);
      for (int i = 0; i < 2; ++i) {
        *lowest = std::min(*lowest, feet[i].lowest);
        for (int c = 0; c < 8; ++c) {
          const mjtNum* now = feet[i].corners.data() + 3 * c;
          const mjtNum* before = previous[i].corners.data() + 3 * c;
          if (now[2] < planted && before[2] < planted) {
            *max_slide = std::max(*max_slide, std::hypot(now[0] - before[0], now[1] - before[1]));
          }
        }
      }
      previous = feet;
    }
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
  ASSERT_EQ(clips_.size(), 9u);
  const char* names[] = {"stand",       "arms",      "squat",      "walk",     "walk_backward",
                         "strafe_left", "turn_left", "walk_start", "walk_stop"};
  for (size_t i = 0; i < clips_.size(); ++i) EXPECT_EQ(clips_[i].clip.name(), names[i]);
  for (const auto& authored : clips_) {
    std::string path = kAssets + "/motions/" + authored.clip.name() + ".json";
    MotionClip shipped = LoadMotion(path);
    // Files carry six decimals; regenerate with ragdoll-author-clips after changing the code.
    const MotionClip& code = authored.clip;
    ASSERT_EQ(shipped.num_frames(), code.num_frames()) << path << ": run ragdoll-author-clips";
    EXPECT_EQ(shipped.loop(), code.loop());
    EXPECT_NEAR(shipped.duration(), code.duration(), 1e-12);
    EXPECT_NEAR(shipped.cycle_yaw(), code.cycle_yaw(), 1e-5) << path;
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
  TrackFeet(walk, 2 * walk.duration() - 1e-9, kPlanted, &lowest, &max_slide);
  RecordProperty("walk_lowest_sole_mm", std::to_string(lowest * 1000));
  RecordProperty("walk_max_slide_per_10ms_mm", std::to_string(max_slide * 1000));
  EXPECT_GT(lowest, -0.002);
  EXPECT_LT(max_slide, 0.003);  // under 3 mm per 10 ms at the worst instant
}

// --- the motion set of a steerable character ---

// Separation of two foot boxes seen from above (separating axes of their sides; negative:
// they overlap), m.
double SoleGap(const std::array<FootState, 2>& feet, const mjData* d, int right_geom,
               int left_geom) {
  double gap = -INFINITY;
  for (int g : {right_geom, left_geom}) {
    const double* r = d->geom_xmat + 9 * g;
    for (int axis = 0; axis < 2; ++axis) {
      double u[2] = {r[axis], r[3 + axis]};
      double norm = std::hypot(u[0], u[1]);
      double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
      for (int foot = 0; foot < 2; ++foot) {
        for (int c = 0; c < 8; ++c) {
          const mjtNum* p = feet[foot].corners.data() + 3 * c;
          double along = (p[0] * u[0] + p[1] * u[1]) / norm;
          lo[foot] = std::min(lo[foot], along);
          hi[foot] = std::max(hi[foot], along);
        }
      }
      gap = std::max(gap, std::max(lo[1] - hi[0], lo[0] - hi[1]));
    }
  }
  return gap;
}

class MotionSetClipsTest : public ProceduralClipsTest,
                           public ::testing::WithParamInterface<const char*> {};

// Every clip of the motion set, as the walk: some foot is always on the floor, no foot sinks
// more than 2 mm, and no corner of a foot box on the floor (within 5 mm) in two samples 10 ms
// apart moves more than 3 mm (the walk's criterion; what moves at all is a foot lifting off or
// touching down, its corners under 5 mm for a few hundredths of a second). Looping clips are
// checked over two cycles, across the seam. The feet never overlap seen from above, and every
// hinge stays within its range.
TEST_P(MotionSetClipsTest, FeetArePlantedFlatWithoutSlidingOrSinking) {
  const MotionClip& clip = Clip(GetParam());
  const mjModel* m = character_->model();
  const int right = mj_name2id(m, mjOBJ_GEOM, "right_ankle");
  const int left = mj_name2id(m, mjOBJ_GEOM, "left_ankle");
  const double kPlanted = 0.005;
  const double end = clip.loop() ? 2 * clip.duration() : clip.duration();
  double max_slide = 0, lowest = 1, closest = 1;
  TrackFeet(clip, end, kPlanted, &lowest, &max_slide, [&](const std::array<FootState, 2>& feet) {
    closest = std::min(closest, SoleGap(feet, data_.get(), right, left));
  });
  RecordProperty("lowest_sole_mm", std::to_string(lowest * 1000));
  RecordProperty("max_slide_per_10ms_mm", std::to_string(max_slide * 1000));
  RecordProperty("closest_feet_mm", std::to_string(closest * 1000));
  EXPECT_GT(lowest, -0.002);
  EXPECT_LT(max_slide, 0.003);
  EXPECT_GT(closest, 0.02);

  std::vector<double> q(3);
  for (int f = 0; f < clip.num_frames(); ++f) {
    for (const auto& h : character_->hinges()) {
      const CharacterJoint& joint = character_->joints()[h.joint];
      DecomposeHinges(joint.axes, clip.frame(f).joint_rotations[h.joint], q.data());
      double angle = q[h.qpos_address - joint.qpos_address];
      EXPECT_GE(angle, h.lower - 1e-9) << h.name << " frame " << f;
      EXPECT_LE(angle, h.upper + 1e-9) << h.name << " frame " << f;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(All, MotionSetClipsTest,
                         ::testing::Values("walk_backward", "strafe_left", "turn_left",
                                           "walk_start", "walk_stop"),
                         [](const auto& test) { return std::string(test.param); });

// The command a looping gait demonstrates, measured from its frames over one cycle: the mean
// root velocity in the clip's initial heading frame, and the mean turn rate.
struct GaitCommand {
  double forward, left, turn;
};

GaitCommand Measure(const MotionClip& clip) {
  const Pose &first = clip.frame(0), &last = clip.frame(clip.num_frames() - 1);
  double heading = YawOf(first.root_rotation);
  double dx = last.root_position[0] - first.root_position[0];
  double dy = last.root_position[1] - first.root_position[1];
  double turn = 0;
  for (int f = 0; f + 1 < clip.num_frames(); ++f) {
    turn += std::remainder(
        YawOf(clip.frame(f + 1).root_rotation) - YawOf(clip.frame(f).root_rotation), 2 * M_PI);
  }
  double d = clip.duration();
  return {(std::cos(heading) * dx + std::sin(heading) * dy) / d,
          (-std::sin(heading) * dx + std::cos(heading) * dy) / d, turn / d};
}

// Each gait demonstrates its design within 5 %: 0.5 m/s backward, 0.4 m/s to the left, 60
// degrees a second to the left on the spot. (Zero components within 5 % of the gait's speed,
// or of 0.1 m/s and 0.1 rad/s.)
TEST_F(ProceduralClipsTest, GaitsDemonstrateTheirCommand) {
  struct Design {
    const char* name;
    GaitCommand command;
  };
  for (const Design& design :
       {Design{"walk_backward", {-0.5, 0, 0}}, Design{"strafe_left", {0, 0.4, 0}},
        Design{"turn_left", {0, 0, M_PI / 3}}}) {
    const MotionClip& clip = Clip(design.name);
    EXPECT_TRUE(clip.loop()) << design.name;
    EXPECT_NEAR(clip.frame_duration(0), 1.0 / 60, 1e-12) << design.name;
    GaitCommand c = Measure(clip);
    const GaitCommand& want = design.command;
    double speed = std::max(std::hypot(want.forward, want.left), 0.1);
    double rate = std::max(std::abs(want.turn), 0.1);
    EXPECT_NEAR(c.forward, want.forward, 0.05 * speed) << design.name;
    EXPECT_NEAR(c.left, want.left, 0.05 * speed) << design.name;
    EXPECT_NEAR(c.turn, want.turn, 0.05 * rate) << design.name;
    RecordProperty(
        std::string(design.name) + "_command",
        std::to_string(c.forward) + " " + std::to_string(c.left) + " " + std::to_string(c.turn));
    // The loop carries on turning: the cycle's turn is the clip's.
    EXPECT_NEAR(clip.cycle_yaw(), c.turn * clip.duration(), 1e-9) << design.name;
  }
  // The turn stays on the spot: the root within 1 cm of where it started, cycle after cycle.
  const MotionClip& turn = Clip("turn_left");
  EXPECT_NEAR(turn.cycle_yaw(), M_PI / 2, 1e-9);
  for (double t = 0; t <= 4 * turn.duration(); t += 0.05) {
    Pose p = turn.Sample(t);
    EXPECT_LT(std::hypot(p.root_position[0], p.root_position[1]), 0.01) << "t=" << t;
  }
  // Facing forward throughout the strafe and the backward walk.
  for (const char* name : {"walk_backward", "strafe_left"}) {
    const MotionClip& clip = Clip(name);
    for (int f = 0; f < clip.num_frames(); ++f) {
      EXPECT_NEAR(YawOf(clip.frame(f).root_rotation), 0, 1e-12) << name << " frame " << f;
    }
  }
}

// Largest angle between the joint rotations of two poses, rad.
double LargestJointAngle(const Pose& a, const Pose& b) {
  double worst = 0;
  for (size_t j = 0; j < a.joint_rotations.size(); ++j) {
    worst = std::max(worst, AngleBetween(a.joint_rotations[j], b.joint_rotations[j]));
  }
  return worst;
}

// walk_start: from stand's first frame exactly, at rest, to the walk's frame 36 (walk phase 0.6,
// the right toe-off) at the walk's speed.
TEST_F(ProceduralClipsTest, WalkStartLeadsFromTheStandIntoTheWalk) {
  const MotionClip& start = Clip("walk_start");
  const MotionClip& stand = Clip("stand");
  const MotionClip& walk = Clip("walk");
  EXPECT_FALSE(start.loop());
  EXPECT_NEAR(start.duration(), 1.2, 1e-12);
  const Pose& first = start.frame(0);
  EXPECT_EQ(first.root_position, stand.frame(0).root_position);
  EXPECT_EQ(first.root_rotation, stand.frame(0).root_rotation);
  EXPECT_EQ(first.joint_rotations, stand.frame(0).joint_rotations);
  Vec3 linear, angular;
  start.SampleRootVelocity(0.001, &linear, &angular);
  EXPECT_NEAR(linear[0], 0, 1e-3);

  // The last frame is the walk's at phase 0.6; no other walk frame comes within 2 degrees.
  const Pose& last = start.frame(start.num_frames() - 1);
  int nearest = -1;
  double nearest_angle = INFINITY;
  for (int f = 0; f < walk.num_frames(); ++f) {
    double angle = LargestJointAngle(last, walk.frame(f));
    if (angle < nearest_angle) {
      nearest_angle = angle;
      nearest = f;
    }
  }
  EXPECT_EQ(nearest, 36);
  EXPECT_LT(nearest_angle, 1e-6);
  EXPECT_NEAR(last.root_position[2], walk.frame(36).root_position[2], 1e-9);
  EXPECT_LT(AngleBetween(last.root_rotation, walk.frame(36).root_rotation), 1e-12);
  start.SampleRootVelocity(start.duration() - 0.001, &linear, &angular);
  EXPECT_NEAR(linear[0], 0.9, 1e-6);
  EXPECT_NEAR(linear[1], 0, 1e-12);
}

// walk_stop: from the walk's frame 36 at the walk's speed to stand's pose, at rest.
TEST_F(ProceduralClipsTest, WalkStopLeadsFromTheWalkToTheStand) {
  const MotionClip& stop = Clip("walk_stop");
  const MotionClip& stand = Clip("stand");
  const MotionClip& walk = Clip("walk");
  EXPECT_FALSE(stop.loop());
  EXPECT_NEAR(stop.duration(), 1.5, 1e-12);
  const Pose& first = stop.frame(0);
  EXPECT_LT(LargestJointAngle(first, walk.frame(36)), 1e-6);
  EXPECT_NEAR(first.root_position[2], walk.frame(36).root_position[2], 1e-9);
  Vec3 linear, angular;
  stop.SampleRootVelocity(0.001, &linear, &angular);
  EXPECT_NEAR(linear[0], 0.9, 1e-6);

  const Pose& last = stop.frame(stop.num_frames() - 1);
  EXPECT_EQ(last.joint_rotations, stand.frame(0).joint_rotations);
  EXPECT_EQ(last.root_rotation, stand.frame(0).root_rotation);
  EXPECT_EQ(last.root_position[2], stand.frame(0).root_position[2]);
  EXPECT_NEAR(last.root_position[0], 0.63, 1e-9);  // 0.2 s at 0.9 m/s, then 0.45 m slowing down
  stop.SampleRootVelocity(stop.duration() - 0.001, &linear, &angular);
  EXPECT_NEAR(std::hypot(linear[0], linear[1]), 0, 1e-9);
}

}  // namespace
}  // namespace ragdoll::motion
