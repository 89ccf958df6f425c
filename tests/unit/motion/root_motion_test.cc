#include "motion/root_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "character/motion_io.h"

namespace ragdoll::motion {

using character::Character;
using character::LoadMotion;
using character::MotionClip;
using character::Pose;
using character::Vec3;

namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;
const std::string kDeepMimic = std::string(RAGDOLL_SHARED_DATA_DIR) + "/deepmimic/motions/";

enum class Removal {
  kAll,    // the hips held over where they start (Mixamo's "In Place")
  kTrend,  // only the steady travel removed, the sway from side to side kept
};

// `clip` as an exporter's in-place option leaves it: the root's horizontal travel removed.
MotionClip InPlace(const MotionClip& clip, Removal removal) {
  const int n = clip.num_frames();
  const Vec3 first = clip.frame(0).root_position, last = clip.frame(n - 1).root_position;
  std::vector<Pose> frames;
  std::vector<double> durations;
  for (int f = 0; f < n; ++f) {
    Pose p = clip.frame(f);
    const double along = clip.frame_time(f) / clip.duration();
    for (int i = 0; i < 2; ++i) {
      p.root_position[i] =
          removal == Removal::kAll ? first[i] : p.root_position[i] - along * (last[i] - first[i]);
    }
    frames.push_back(p);
    durations.push_back(clip.frame_duration(f));
  }
  return MotionClip(clip.name() + "_in_place", clip.loop(), durations, frames,
                    clip.cycle_transform());
}

Vec3 Travel(const MotionClip& clip) {
  const Vec3 a = clip.frame(0).root_position, b = clip.frame(clip.num_frames() - 1).root_position;
  return {b[0] - a[0], b[1] - a[1], 0};
}

double Length(const Vec3& v) { return std::hypot(v[0], v[1]); }

double HeadingDifferenceDegrees(const Vec3& a, const Vec3& b) {
  double d = std::atan2(b[1], b[0]) - std::atan2(a[1], a[0]);
  d = std::remainder(d, 2 * M_PI);
  return std::fabs(d) * 180 / M_PI;
}

class RootMotionTest : public ::testing::Test {
 protected:
  RootMotionTest() : character_(Character::Load(kAssets + "/character/humanoid.xml")) {}

  static MotionClip Clip(const std::string& name) {
    return LoadMotion(name.find("humanoid3d") == 0 ? kDeepMimic + name + ".txt"
                                                   : kAssets + "/motions/" + name + ".json");
  }

  std::shared_ptr<const Character> character_;
};

struct InPlaceCase {
  std::string clip;
  double tolerance;  // of the true travel
};

class InPlaceTest : public RootMotionTest, public ::testing::WithParamInterface<InPlaceCase> {};

// Locomotion whose true travel is known: the shipped clips (planted feet held still by
// construction) and DeepMimic's captures (feet that slip a little, a run with flight phases).
TEST_P(InPlaceTest, RebuildsTheTravelOfAnInPlaceVariantFromTheFeet) {
  const MotionClip original = Clip(GetParam().clip);
  const Vec3 truth = Travel(original);
  ASSERT_GT(Length(truth), 0.3) << "a clip that travels";
  // How fast the capture's own planted feet slip with its own root.
  RootMotionReport as_captured;
  ReconstructRootMotion(original, *character_, RootMotion::kAuto, &as_captured);
  EXPECT_FALSE(as_captured.in_place);
  for (Removal removal : {Removal::kAll, Removal::kTrend}) {
    SCOPED_TRACE(removal == Removal::kAll ? "all travel removed" : "trend removed");
    const MotionClip in_place = InPlace(original, removal);
    EXPECT_NEAR(Length(Travel(in_place)), 0, 1e-9);

    RootMotionReport report;
    const MotionClip rebuilt =
        ReconstructRootMotion(in_place, *character_, RootMotion::kAuto, &report);
    EXPECT_TRUE(report.in_place) << report.Summary();
    EXPECT_TRUE(report.reconstructed);
    const Vec3 travel = Travel(rebuilt);
    // The figures docs/motion-import.md quotes.
    std::printf("%s, %s: true travel %.3f m, rebuilt %.3f m (%+.1f %%), heading off %.1f deg\n",
                GetParam().clip.c_str(), removal == Removal::kAll ? "all removed" : "trend removed",
                Length(truth), Length(travel), 100 * (Length(travel) / Length(truth) - 1),
                HeadingDifferenceDegrees(travel, truth));
    EXPECT_NEAR(Length(travel), Length(truth), GetParam().tolerance * Length(truth))
        << report.Summary() << "; true travel " << Length(truth);
    EXPECT_LT(HeadingDifferenceDegrees(travel, truth), 3) << report.Summary();
    // Heights, rotations and timing are the clip's own.
    ASSERT_EQ(rebuilt.num_frames(), in_place.num_frames());
    for (int f = 0; f < rebuilt.num_frames(); f += 7) {
      EXPECT_EQ(rebuilt.frame(f).root_position[2], in_place.frame(f).root_position[2]);
      EXPECT_EQ(rebuilt.frame(f).root_rotation, in_place.frame(f).root_rotation);
      for (size_t j = 0; j < rebuilt.frame(f).joint_rotations.size(); ++j) {
        for (int k = 0; k < 4; ++k) {
          EXPECT_NEAR(rebuilt.frame(f).joint_rotations[j][k],
                      in_place.frame(f).joint_rotations[j][k], 1e-12);
        }
      }
      EXPECT_EQ(rebuilt.frame_duration(f), in_place.frame_duration(f));
    }
    // The treadmill's planted feet slid at the clip's speed; rebuilt, they slip no more than the
    // capture's own did.
    EXPECT_GT(Length(report.slide_velocity), 0.8 * Length(truth) / original.duration());
    RootMotionReport after;
    ReconstructRootMotion(rebuilt, *character_, RootMotion::kAuto, &after);
    EXPECT_FALSE(after.in_place);
    EXPECT_LT(Length(after.slide_velocity), Length(as_captured.slide_velocity) + 0.05)
        << after.Summary();
  }
}

INSTANTIATE_TEST_SUITE_P(Locomotion, InPlaceTest,
                         ::testing::Values(InPlaceCase{"walk", 0.03},
                                           InPlaceCase{"walk_backward", 0.03},
                                           InPlaceCase{"strafe_left", 0.03},
                                           InPlaceCase{"humanoid3d_walk", 0.03},
                                           InPlaceCase{"humanoid3d_run", 0.03},
                                           // Its root moves 15 % faster in flight than its
                                           // planted feet carry it in stance: 11 % short.
                                           InPlaceCase{"humanoid3d_jog", 0.12}),
                         [](const auto& test) { return test.param.clip; });

TEST_F(RootMotionTest, LeavesClipsWithTheirOwnTravelOrNoneAlone) {
  // Travelling clips, a turn on the spot and clips that stay put: none is in place, and each
  // comes back exactly as it was.
  for (const std::string name : {"walk", "walk_backward", "strafe_left", "turn_left", "stand",
                                 "squat", "arms", "humanoid3d_walk", "humanoid3d_run"}) {
    SCOPED_TRACE(name);
    const MotionClip clip = Clip(name);
    RootMotionReport report;
    const MotionClip out = ReconstructRootMotion(clip, *character_, RootMotion::kAuto, &report);
    EXPECT_FALSE(report.in_place) << report.Summary();
    EXPECT_FALSE(report.reconstructed);
    ASSERT_EQ(out.num_frames(), clip.num_frames());
    for (int f = 0; f < clip.num_frames(); ++f) {
      ASSERT_EQ(out.frame(f).root_position, clip.frame(f).root_position) << f;
    }
  }
}

TEST_F(RootMotionTest, FeetModeOnAClipWithRealTravelAddsOnlyItsFeetsSlip) {
  // The shipped walk's planted feet do not move: rebuilding from them adds (almost) nothing.
  const MotionClip walk = Clip("walk");
  RootMotionReport report;
  ReconstructRootMotion(walk, *character_, RootMotion::kFeet, &report);
  EXPECT_TRUE(report.reconstructed);
  EXPECT_FALSE(report.in_place);
  EXPECT_LT(Length(report.added_travel), 0.01 * Length(Travel(walk))) << report.Summary();
}

TEST_F(RootMotionTest, KeepModeDoesNothingAndNamesAreChecked) {
  const MotionClip in_place = InPlace(Clip("walk"), Removal::kAll);
  RootMotionReport report;
  const MotionClip out = ReconstructRootMotion(in_place, *character_, RootMotion::kKeep, &report);
  EXPECT_FALSE(report.reconstructed);
  EXPECT_EQ(Length(Travel(out)), 0);
  EXPECT_EQ(ParseRootMotion("auto"), RootMotion::kAuto);
  EXPECT_EQ(ParseRootMotion("feet"), RootMotion::kFeet);
  EXPECT_EQ(ParseRootMotion("keep"), RootMotion::kKeep);
  try {
    ParseRootMotion("yes");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "root motion: 'yes' is not one of auto, feet, keep");
  }
}

}  // namespace
}  // namespace ragdoll::motion
