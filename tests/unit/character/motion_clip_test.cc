#include "character/motion_clip.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "character/character.h"
#include "character/motion_io.h"
#include "character/skeleton.h"
#include "common/config_section.h"
#include "tests/unit/error_of.h"

namespace ragdoll::character {
namespace {

using ::testing::HasSubstr;

const std::string kDeepMimicMotions =
    std::string(RAGDOLL_SHARED_DATA_DIR) + "/deepmimic/motions/humanoid3d_";
const std::string kAssets = RAGDOLL_ASSETS_DIR;

MotionClip LoadDeepMimic(const std::string& name) {
  return LoadMotion(kDeepMimicMotions + name + ".txt");
}

void ExpectVecNear(const Vec3& actual, const Vec3& expected, double tolerance,
                   const std::string& what) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(actual[k], expected[k], tolerance) << what << " [" << k << "]";
  }
}

void ExpectQuatNear(const Quat& actual, const Quat& expected, double tolerance,
                    const std::string& what) {
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR(actual[k], expected[k], tolerance) << what << " [" << k << "]";
  }
}

void ExpectPoseNear(const Pose& actual, const Pose& expected, double tolerance,
                    const std::string& what) {
  ExpectVecNear(actual.root_position, expected.root_position, tolerance, what + " root position");
  ExpectQuatNear(actual.root_rotation, expected.root_rotation, tolerance, what + " root rotation");
  ASSERT_EQ(actual.joint_rotations.size(), expected.joint_rotations.size()) << what;
  for (size_t j = 0; j < expected.joint_rotations.size(); ++j) {
    ExpectQuatNear(actual.joint_rotations[j], expected.joint_rotations[j], tolerance,
                   what + " " + Humanoid3dJoints()[j].name);
  }
}

std::string ParseError(const std::string& text, const std::string& origin) {
  return ConfigErrorOf([&] { ParseMotion(text, origin); });
}

// Replaces the single occurrence of `from` in `text`.
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << from << " occurs twice";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// --- DeepMimic files ---

struct ClipFacts {
  const char* name;
  int frames;
  double duration;
};

// Names the parameter in test listings (ctest shows it).
void PrintTo(const ClipFacts& facts, std::ostream* out) { *out << facts.name; }

class DeepMimicClips : public ::testing::TestWithParam<ClipFacts> {};

TEST_P(DeepMimicClips, HaveTheirFrameCountDurationAndLoop) {
  const ClipFacts& facts = GetParam();
  MotionClip clip = LoadDeepMimic(facts.name);
  EXPECT_EQ(clip.name(), std::string("humanoid3d_") + facts.name);
  EXPECT_EQ(clip.num_frames(), facts.frames);
  EXPECT_NEAR(clip.duration(), facts.duration, 1e-5);
  EXPECT_TRUE(clip.loop());  // all four say "Loop": "wrap"
  EXPECT_EQ(clip.frame(0).joint_rotations.size(), Humanoid3dJoints().size());
  // Looping clips move only horizontally from cycle to cycle.
  EXPECT_EQ(clip.cycle_displacement()[2], 0.0);
}

// DeepMimic's published library carries rotations whose norms are off by up to ~15 %; they are
// normalised on reading, as DeepMimic does. A copy of each clip with every quaternion scaled to
// norm `scale` loads into the same clip and reports what it renormalised.
void ExpectLoadsDenormalised(const std::string& name, double scale) {
  std::ifstream in(kDeepMimicMotions + name + ".txt");
  nlohmann::json doc = nlohmann::json::parse(in);
  int quaternions = 0;
  for (auto& frame : doc["Frames"]) {
    auto scale_at = [&](size_t k) {
      double norm = 0;
      for (size_t c = 0; c < 4; ++c)
        norm += frame[k + c].get<double>() * frame[k + c].get<double>();
      for (size_t c = 0; c < 4; ++c)
        frame[k + c] = frame[k + c].get<double>() * scale / std::sqrt(norm);
      ++quaternions;
    };
    scale_at(4);  // root rotation
    size_t k = 8;
    for (const auto& joint : Humanoid3dJoints()) {
      if (joint.type == JointType::kSpherical) {
        scale_at(k);
        k += 4;
      } else {
        k += 1;
      }
    }
  }
  MotionClip original = LoadDeepMimic(name);
  MotionClip scaled = ParseMotion(doc.dump(), name + "_scaled.txt");
  EXPECT_EQ(original.renormalized_rotations(), 0) << name;
  EXPECT_LT(original.max_norm_deviation(), 2e-6) << name;
  EXPECT_EQ(scaled.renormalized_rotations(), quaternions) << name;
  EXPECT_NEAR(scaled.max_norm_deviation(), std::abs(scale - 1), 1e-12) << name;
  ASSERT_EQ(scaled.num_frames(), original.num_frames());
  for (int f = 0; f < original.num_frames(); ++f) {
    ExpectPoseNear(scaled.frame(f), original.frame(f), 1e-12,
                   name + " x" + std::to_string(scale) + " frame " + std::to_string(f));
  }
}

TEST_P(DeepMimicClips, LoadWithDenormalisedRotations) {
  for (double scale : {0.85, 1.06}) ExpectLoadsDenormalised(GetParam().name, scale);
}

INSTANTIATE_TEST_SUITE_P(All, DeepMimicClips,
                         ::testing::Values(ClipFacts{"walk", 39, 1.266616},
                                           ClipFacts{"run", 25, 0.799968},
                                           ClipFacts{"jog", 26, 0.8333325},
                                           ClipFacts{"spinkick", 78, 1.283282}),
                         [](const auto& test) { return std::string(test.param.name); });

TEST(DeepMimicWalk, IsConvertedToZUp) {
  MotionClip walk = LoadDeepMimic("walk");
  // The file's first root position is (0, 0.847532, 0) Y-up, the last (1.23859, 0.847532, -0):
  // (x, y, z) -> (x, -z, y).
  ExpectVecNear(walk.frame(0).root_position, {0, 0, 0.847532}, 1e-12, "first");
  ExpectVecNear(walk.frame(38).root_position, {1.23859, 0, 0.847532}, 1e-12, "last");
  ExpectVecNear(walk.cycle_displacement(), {1.23859, 0, 0}, 1e-12, "displacement");
  EXPECT_DOUBLE_EQ(walk.frame_duration(0), 0.033332);
  EXPECT_DOUBLE_EQ(walk.frame_time(1), 0.033332);
  EXPECT_NEAR(walk.frame_time(38), 38 * 0.033332, 1e-12);
}

TEST(DeepMimicSpinkick, CycleDisplacementIsHorizontal) {
  MotionClip spinkick = LoadDeepMimic("spinkick");
  // Root from (0, 0.825094, 0) to (-0.3998675593, 0.825094, -0.2750092869) Y-up, that is
  // (-0.3998675593, 0.2750092869, 0.825094) Z-up; the height does not change.
  ExpectVecNear(spinkick.cycle_displacement(), {-0.3998675593, 0.2750092869, 0}, 1e-12,
                "displacement");
}

// --- sampling ---

TEST(MotionClipSample, AtAKeyFrameTimeReturnsThatFrame) {
  MotionClip walk = LoadDeepMimic("walk");
  for (int i = 0; i + 1 < walk.num_frames(); ++i) {
    ExpectPoseNear(walk.Sample(walk.frame_time(i)), walk.frame(i), 1e-12,
                   "frame " + std::to_string(i));
  }
  // The end of a cycle is the start of the next: frame 0, advanced by one displacement, which
  // puts the root where the file's last frame has it.
  Pose end = walk.Sample(walk.duration());
  ExpectVecNear(end.root_position, walk.frame(38).root_position, 1e-12, "end root position");
  ExpectQuatNear(end.root_rotation, walk.frame(0).root_rotation, 1e-12, "end root rotation");
}

TEST(MotionClipSample, HalfwayInterpolates) {
  MotionClip walk = LoadDeepMimic("walk");
  for (int i = 0; i + 1 < walk.num_frames(); ++i) {
    const Pose& a = walk.frame(i);
    const Pose& b = walk.frame(i + 1);
    std::string label = "between frames " + std::to_string(i) + " and " + std::to_string(i + 1);
    Pose mid = walk.Sample(walk.frame_time(i) + 0.5 * walk.frame_duration(i));
    Vec3 midpoint;
    for (int k = 0; k < 3; ++k) midpoint[k] = 0.5 * (a.root_position[k] + b.root_position[k]);
    ExpectVecNear(mid.root_position, midpoint, 1e-9, label);
    ExpectQuatNear(mid.root_rotation, Slerp(a.root_rotation, b.root_rotation, 0.5), 1e-9, label);
    // Halfway along the arc: as far from either key frame.
    double half = 0.5 * AngleBetween(a.root_rotation, b.root_rotation);
    EXPECT_NEAR(AngleBetween(a.root_rotation, mid.root_rotation), half, 1e-7) << label;
    EXPECT_NEAR(AngleBetween(mid.root_rotation, b.root_rotation), half, 1e-7) << label;
    for (size_t j = 0; j < a.joint_rotations.size(); ++j) {
      ExpectQuatNear(mid.joint_rotations[j], Slerp(a.joint_rotations[j], b.joint_rotations[j], 0.5),
                     1e-9, label + " " + Humanoid3dJoints()[j].name);
    }
  }
}

TEST(MotionClipSample, LoopingAdvancesTheRootEachCycle) {
  MotionClip walk = LoadDeepMimic("walk");
  double d = walk.duration();
  const Vec3& shift = walk.cycle_displacement();
  for (double t : {0.01, 0.3, 0.65, 1.2}) {
    Pose base = walk.Sample(t);
    for (int cycles : {1, 2, -1}) {
      Pose later = walk.Sample(t + cycles * d);
      Pose expected = base;
      for (int k = 0; k < 3; ++k) expected.root_position[k] += cycles * shift[k];
      ExpectPoseNear(later, expected, 1e-9,
                     "t " + std::to_string(t) + " cycles " + std::to_string(cycles));
    }
  }
  // Two cycles of walking: 2 x 1.23859 m along +x.
  EXPECT_NEAR(walk.Sample(0.3 + 2 * d).root_position[0] - walk.Sample(0.3).root_position[0],
              2 * 1.23859, 1e-9);
}

TEST(MotionClipSample, SampleIntoMatchesSample) {
  MotionClip walk = LoadDeepMimic("walk");
  Pose reused;
  for (double t : {0.0, 0.4, 1.0, 2.9}) {
    walk.SampleInto(t, &reused);
    ExpectPoseNear(reused, walk.Sample(t), 0, "t " + std::to_string(t));
  }
}

TEST(MotionClipSampleVelocity, MatchesAFiniteDifferenceOfSample) {
  MotionClip walk = LoadDeepMimic("walk");
  // A central difference inside one segment. Root positions are linear in time, so they match
  // to rounding. Rotations match to the slerp's own accuracy: for key frames closer than
  // acos(0.9995) in quaternion angle Slerp() blends linearly, whose rate departs from the mean by
  // up to ~ angle^2 / 6 = 2e-4 relative.
  const double h = 1e-6;
  double worst_relative = 0;
  for (int i = 0; i + 1 < walk.num_frames(); ++i) {
    std::string label = "segment " + std::to_string(i);
    for (double fraction : {0.25, 0.5, 0.75}) {
      double t = walk.frame_time(i) + fraction * walk.frame_duration(i);
      PoseVelocity v = walk.SampleVelocity(t);
      Pose before = walk.Sample(t - h);
      Pose after = walk.Sample(t + h);
      Vec3 linear;
      for (int k = 0; k < 3; ++k) {
        linear[k] = (after.root_position[k] - before.root_position[k]) / (2 * h);
      }
      ExpectVecNear(v.root_linear, linear, 1e-6, label + " root linear");
      auto check_angular = [&](const Vec3& actual, const Quat& from, const Quat& to,
                               const std::string& what) {
        Vec3 expected = AngularVelocity(from, to, 2 * h);
        double speed = std::sqrt(expected[0] * expected[0] + expected[1] * expected[1] +
                                 expected[2] * expected[2]);
        for (int k = 0; k < 3; ++k) {
          double error = std::abs(actual[k] - expected[k]);
          worst_relative = std::max(worst_relative, error / std::max(speed, 1.0));
          EXPECT_NEAR(actual[k], expected[k], 1e-3 * std::max(speed, 1.0))
              << what << " [" << k << "]";
        }
      };
      check_angular(v.root_angular, before.root_rotation, after.root_rotation,
                    label + " root angular");
      ASSERT_EQ(v.joint_angular.size(), Humanoid3dJoints().size());
      for (size_t j = 0; j < v.joint_angular.size(); ++j) {
        check_angular(v.joint_angular[j], before.joint_rotations[j], after.joint_rotations[j],
                      label + " " + Humanoid3dJoints()[j].name);
      }
    }
  }
  std::cout << "SampleVelocity vs finite difference: worst error " << worst_relative
            << " x max(speed, 1 rad/s)\n";
}

// --- hand-made clips ---

Pose RestPose(const Vec3& root_position) {
  Pose pose;
  pose.root_position = root_position;
  pose.joint_rotations.assign(Humanoid3dJoints().size(), kIdentityQuat);
  return pose;
}

TEST(MotionClipSampleVelocity, AngularVelocitiesAreInTheChildFrame) {
  // The root faces +y (90 degrees about z) and rolls 0.1 rad about its own x axis in 0.1 s:
  // 1 rad/s about local x (world y would read (0, 1, 0)). The chest, already turned 0.5 rad
  // about z, turns 0.2 rad about its own x: 2 rad/s about local x.
  Pose a = RestPose({0, 0, 1});
  Pose b = RestPose({0.3, -0.1, 1});
  a.root_rotation = AxisAngle({0, 0, 1}, M_PI / 2);
  b.root_rotation = Multiply(a.root_rotation, AxisAngle({1, 0, 0}, 0.1));
  a.joint_rotations[0] = AxisAngle({0, 0, 1}, 0.5);
  b.joint_rotations[0] = Multiply(a.joint_rotations[0], AxisAngle({1, 0, 0}, 0.2));
  MotionClip clip("roll", false, {0.1, 0.1}, {a, b});
  PoseVelocity v = clip.SampleVelocity(0.05);
  ExpectVecNear(v.root_linear, {3, -1, 0}, 1e-12, "root linear");  // (0.3, -0.1, 0) m / 0.1 s
  ExpectVecNear(v.root_angular, {1, 0, 0}, 1e-9, "root angular");
  ExpectVecNear(v.joint_angular[0], {2, 0, 0}, 1e-9, "chest");
  ExpectVecNear(v.joint_angular[1], {0, 0, 0}, 1e-12, "neck");
}

TEST(MotionClip, NonLoopingClipHoldsItsEndsAndClampsPhase) {
  // Three frames 0.4 s and 0.6 s apart, the root at x = 0, 1 and 4.
  MotionClip clip("once", false, {0.4, 0.6, 0},
                  {RestPose({0, 0, 1}), RestPose({1, 0, 1}), RestPose({4, 0, 1})});
  EXPECT_FALSE(clip.loop());
  EXPECT_DOUBLE_EQ(clip.duration(), 1.0);
  ExpectVecNear(clip.cycle_displacement(), {0, 0, 0}, 0, "displacement");
  EXPECT_NEAR(clip.Sample(0.2).root_position[0], 0.5, 1e-12);  // halfway from 0 to 1
  EXPECT_NEAR(clip.Sample(0.7).root_position[0], 2.5, 1e-12);  // halfway from 1 to 4
  EXPECT_EQ(clip.Sample(-1).root_position[0], 0.0);
  EXPECT_EQ(clip.Sample(5).root_position[0], 4.0);
  EXPECT_NEAR(clip.SampleVelocity(0.2).root_linear[0], 2.5, 1e-12);  // 1 m / 0.4 s
  EXPECT_NEAR(clip.SampleVelocity(0.7).root_linear[0], 5.0, 1e-12);  // 3 m / 0.6 s
  EXPECT_EQ(clip.SampleVelocity(-1).root_linear[0], 0.0);
  EXPECT_EQ(clip.SampleVelocity(5).root_linear[0], 0.0);
  EXPECT_EQ(clip.SampleVelocity(5).joint_angular.size(), Humanoid3dJoints().size());
  EXPECT_EQ(clip.Phase(-1), 0.0);
  EXPECT_NEAR(clip.Phase(0.3), 0.3, 1e-15);
  EXPECT_EQ(clip.Phase(2), 1.0);
}

TEST(MotionClip, PhaseWrapsForALoopingClip) {
  MotionClip walk = LoadDeepMimic("walk");
  double d = walk.duration();
  EXPECT_EQ(walk.Phase(0), 0.0);
  EXPECT_NEAR(walk.Phase(0.5 * d), 0.5, 1e-12);
  EXPECT_NEAR(walk.Phase(1.25 * d), 0.25, 1e-12);
  EXPECT_NEAR(walk.Phase(3.9 * d), 0.9, 1e-12);
  EXPECT_NEAR(walk.Phase(-0.25 * d), 0.75, 1e-12);
}

// --- looping clips that turn ---

// A clip that turns 90 degrees counter-clockwise per 1.2 s cycle along an arc, pitching and
// rolling a little on the way, its joints moving: 13 frames, the last the first turned by 90
// degrees about the pivot (0.3, -0.2) and moved by (0.5, 0.4).
MotionClip TurningClip() {
  std::vector<Pose> frames;
  const int n = 12;
  for (int i = 0; i <= n; ++i) {
    double u = static_cast<double>(i % n) / n;  // the last frame is the first, moved
    Pose pose = RestPose({0.3 + 0.5 * u + 0.05 * std::sin(2 * M_PI * u),
                          -0.2 + 0.4 * u * u + 0.03 * std::sin(4 * M_PI * u),
                          0.9 + 0.02 * std::cos(2 * M_PI * u)});
    double yaw = 0.4 + 0.5 * M_PI * u + 0.1 * std::sin(2 * M_PI * u);
    pose.root_rotation = Multiply(AxisAngle({0, 0, 1}, yaw),
                                  Multiply(AxisAngle({0, 1, 0}, 0.1 * std::sin(2 * M_PI * u)),
                                           AxisAngle({1, 0, 0}, 0.05 * std::cos(2 * M_PI * u))));
    pose.joint_rotations[3] = AxisAngle({0, 1, 0}, 0.5 + 0.4 * std::sin(2 * M_PI * u));
    pose.joint_rotations[0] = AxisAngle({0.6, 0, 0.8}, 0.2 * std::cos(2 * M_PI * u));
    if (i == n) {
      Vec3 p = frames[0].root_position;
      double x = p[0] - 0.3, y = p[1] + 0.2;
      pose.root_position = {0.3 + 0.5 - y, -0.2 + 0.4 + x, p[2]};
      pose.root_rotation = Multiply(AxisAngle({0, 0, 1}, M_PI / 2), frames[0].root_rotation);
    }
    frames.push_back(std::move(pose));
  }
  return MotionClip("turn", true, std::vector<double>(n + 1, 0.1), std::move(frames));
}

// The cycle transform, applied `cycles` times by hand: turn by 90 degrees about the first
// frame's root (0.3, -0.2), then move by the first-to-last displacement (0.5, 0.4); backwards
// for negative counts.
void ApplyTurnCycles(int cycles, Vec3* position, Quat* rotation) {
  for (int c = 0; c < std::abs(cycles); ++c) {
    double x = (*position)[0], y = (*position)[1];
    if (cycles > 0) {
      x -= 0.3;
      y += 0.2;
      (*position)[0] = 0.3 + 0.5 - y;
      (*position)[1] = -0.2 + 0.4 + x;
    } else {
      x -= 0.3 + 0.5;
      y -= -0.2 + 0.4;
      (*position)[0] = 0.3 + y;
      (*position)[1] = -0.2 - x;
    }
    *rotation = Multiply(AxisAngle({0, 0, 1}, cycles > 0 ? M_PI / 2 : -M_PI / 2), *rotation);
  }
}

TEST(MotionClipCycle, ATurningClipLoopsThroughThePlanarTransform) {
  MotionClip clip = TurningClip();
  EXPECT_EQ(clip.cycle_transform(), CycleTransform::kPlanar);
  EXPECT_NEAR(clip.cycle_yaw(), M_PI / 2, 1e-12);
  ExpectVecNear(clip.cycle_displacement(), {0.5, 0.4, 0}, 1e-12, "displacement");
  const double d = clip.duration();
  // Times between key frames: the velocity is the segment's, so a time on a key frame could
  // land on either side of it after adding whole cycles.
  for (double t : {0.03, 0.05, 0.37, 0.63, 1.13}) {
    Pose base = clip.Sample(t);
    Vec3 linear, angular;
    clip.SampleRootVelocity(t, &linear, &angular);
    for (int cycles : {2, 1, -1, -3, 7}) {
      std::string label = "t " + std::to_string(t) + " cycles " + std::to_string(cycles);
      Pose expected = base;
      ApplyTurnCycles(cycles, &expected.root_position, &expected.root_rotation);
      Pose later = clip.Sample(t + cycles * d);
      ExpectVecNear(later.root_position, expected.root_position, 1e-9, label);
      EXPECT_LT(AngleBetween(later.root_rotation, expected.root_rotation), 1e-9) << label;
      for (size_t j = 0; j < base.joint_rotations.size(); ++j) {
        EXPECT_LT(AngleBetween(later.joint_rotations[j], base.joint_rotations[j]), 1e-9) << label;
      }
      // The linear velocity turns with the cycles; the angular one is in the root's own frame.
      Vec3 later_linear, later_angular;
      clip.SampleRootVelocity(t + cycles * d, &later_linear, &later_angular);
      Vec3 turned = Rotate(AxisAngle({0, 0, 1}, cycles * M_PI / 2), linear);
      ExpectVecNear(later_linear, turned, 1e-9, label + " linear velocity");
      ExpectVecNear(later_angular, angular, 1e-9, label + " angular velocity");
      EXPECT_EQ(clip.SampleVelocity(t + cycles * d).root_linear, later_linear) << label;
    }
  }
  // Seamless: the end of a cycle is the start of the next, which is the last frame.
  Pose end = clip.Sample(d);
  ExpectVecNear(end.root_position, clip.frame(12).root_position, 1e-12, "end");
  EXPECT_LT(AngleBetween(end.root_rotation, clip.frame(12).root_rotation), 1e-12);
  Pose before = clip.Sample(d - 1e-7), after = clip.Sample(d + 1e-7);
  ExpectVecNear(before.root_position, after.root_position, 1e-6, "across the seam");
  EXPECT_LT(AngleBetween(before.root_rotation, after.root_rotation), 1e-5);
  // Four cycles turn the root all the way round: back where it started, facing the same way.
  Pose round = clip.Sample(0.37 + 4 * d), start = clip.Sample(0.37);
  ExpectVecNear(round.root_position, start.root_position, 1e-9, "four cycles");
  EXPECT_LT(AngleBetween(round.root_rotation, start.root_rotation), 1e-9);
}

// Without a turn, looping is the translation it always was, to the last bit.
TEST(MotionClipCycle, WithoutATurnTheRootTranslatesExactlyAsBefore) {
  std::vector<Pose> frames;
  for (int i = 0; i <= 10; ++i) {
    frames.push_back(RestPose({0.13 * i + 0.01 * std::sin(i), 0.02 * std::cos(i), 0.9}));
    frames.back().root_rotation = AxisAngle({0, 1, 0}, 0.1 * std::sin(i));  // pitch only
  }
  frames.back().root_rotation = frames.front().root_rotation;
  frames.back().root_position[1] = frames.front().root_position[1] + 0.05;
  MotionClip clip("straight", true, std::vector<double>(11, 0.1), frames);
  EXPECT_EQ(clip.cycle_yaw(), 0.0);
  const Vec3 shift = clip.cycle_displacement();
  const double d = clip.duration();
  for (double t : {0.0, 0.05, 0.42, 0.99, 2.37, -0.3, -1.61, 13.7}) {
    // The root as MotionClip sampled it before turning clips: interpolation plus whole cycles
    // of displacement.
    double cycles = std::floor(t / d), local = t - cycles * d;
    int i = std::min(static_cast<int>(local / 0.1), 9);
    while (i > 0 && clip.frame_time(i) > local) --i;
    while (i < 9 && clip.frame_time(i + 1) <= local) ++i;
    double alpha =
        std::fmin(std::fmax((local - clip.frame_time(i)) / clip.frame_duration(i), 0.0), 1.0);
    const Pose &a = clip.frame(i), &b = clip.frame(i + 1);
    Pose sample = clip.Sample(t);
    for (int k = 0; k < 3; ++k) {
      double expected =
          (1 - alpha) * a.root_position[k] + alpha * b.root_position[k] + cycles * shift[k];
      EXPECT_EQ(sample.root_position[k], expected) << "t " << t << " [" << k << "]";
    }
    EXPECT_EQ(sample.root_rotation, Slerp(a.root_rotation, b.root_rotation, alpha)) << "t " << t;
    Vec3 linear, angular;
    clip.SampleRootVelocity(t, &linear, &angular);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(linear[k], (b.root_position[k] - a.root_position[k]) / clip.frame_duration(i));
    }
  }
}

// DeepMimic's motion files loop by translation (its first and last walk headings differ by
// 6.9 degrees, which would otherwise turn the walk into a circle); the project's format keeps
// which transform a clip loops by.
TEST(MotionClipCycle, DeepMimicClipsLoopByTranslationThroughEveryFormat) {
  MotionClip walk = LoadDeepMimic("walk");
  EXPECT_EQ(walk.cycle_transform(), CycleTransform::kTranslation);
  EXPECT_EQ(walk.cycle_yaw(), 0.0);
  EXPECT_NEAR(
      std::remainder(YawOf(walk.frame(38).root_rotation) - YawOf(walk.frame(0).root_rotation),
                     2 * M_PI),
      6.886 * M_PI / 180, 1e-3);
  std::string text = FormatClip(walk, "");
  EXPECT_THAT(text, HasSubstr("\"cycle\": \"translation\""));
  MotionClip back = ParseMotion(text, "walk.json");
  EXPECT_EQ(back.cycle_transform(), CycleTransform::kTranslation);
  EXPECT_EQ(back.cycle_yaw(), 0.0);

  // A turning clip written and read back turns the same; its file needs no "cycle" field.
  MotionClip turn = TurningClip();
  std::string turn_text = FormatClip(turn, "");
  EXPECT_THAT(turn_text, ::testing::Not(HasSubstr("\"cycle\"")));
  MotionClip turn_back = ParseMotion(turn_text, "turn.json");
  EXPECT_EQ(turn_back.cycle_transform(), CycleTransform::kPlanar);
  EXPECT_NEAR(turn_back.cycle_yaw(), M_PI / 2, 1e-5);
  EXPECT_THAT(
      ParseError(Replace(turn_text, "\"loop\": true", "\"loop\": true, \"cycle\": 3"), "turn.json"),
      HasSubstr("turn.json: cycle: expected \"planar\" or \"translation\", got 3"));
}

std::string InvalidClipMessage(std::vector<double> durations, std::vector<Pose> frames) {
  try {
    MotionClip clip("bad", true, std::move(durations), std::move(frames));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected std::invalid_argument";
  return "";
}

TEST(MotionClip, RejectsInvalidFramesNamingFrameAndField) {
  Pose rest = RestPose({0, 0, 1});
  EXPECT_THAT(InvalidClipMessage({0.1}, {rest}), HasSubstr("at least two frames, got 1"));
  EXPECT_THAT(InvalidClipMessage({0.1}, {rest, rest}), HasSubstr("1 frame durations for 2"));
  EXPECT_THAT(InvalidClipMessage({0.1, -0.1, 0}, {rest, rest, rest}),
              HasSubstr("frame 1: duration must be positive"));
  EXPECT_THAT(InvalidClipMessage({NAN, 0.1}, {rest, rest}),
              HasSubstr("frame 0: duration must be positive"));
  Pose degenerate = rest;
  degenerate.joint_rotations[9] = {0, 0, 0, 0};
  EXPECT_THAT(InvalidClipMessage({0.1, 0.1}, {rest, degenerate}),
              HasSubstr("frame 1: left_ankle: quaternion norm 0.000000 is too far from 1"));
  degenerate.joint_rotations[9] = {2, 0, 0.5, 0};  // norm 2.06
  EXPECT_THAT(InvalidClipMessage({0.1, 0.1}, {rest, degenerate}),
              HasSubstr("frame 1: left_ankle: quaternion norm 2.061553 is too far from 1"));
  degenerate.joint_rotations[9] = {1, NAN, 0, 0};
  EXPECT_THAT(InvalidClipMessage({0.1, 0.1}, {degenerate, rest}),
              HasSubstr("frame 0: left_ankle: quaternion is not finite"));
  degenerate = rest;
  degenerate.root_rotation = {INFINITY, 0, 0, 0};
  EXPECT_THAT(InvalidClipMessage({0.1, 0.1}, {rest, degenerate}),
              HasSubstr("frame 1: root rotation: quaternion is not finite"));
  Pose short_pose = rest;
  short_pose.joint_rotations.pop_back();
  EXPECT_THAT(InvalidClipMessage({0.1, 0.1}, {short_pose, rest}),
              HasSubstr("frame 0: expected 12 joint rotations, got 11"));
}

// --- DeepMimic format ---

// Index of a field in a DeepMimic frame: duration, root position (3), root rotation (4), then
// per joint a quaternion (spherical) or an angle (revolute); 44 values for humanoid3d.
int DeepMimicIndex(const std::string& joint) {
  int index = 8;
  for (const auto& j : Humanoid3dJoints()) {
    if (j.name == joint) return index;
    index += j.type == JointType::kSpherical ? 4 : 1;
  }
  ADD_FAILURE() << "no joint " << joint;
  return -1;
}

std::vector<double> DeepMimicRestFrame(double duration) {
  std::vector<double> values = {duration, 0, 0.9, 0, 1, 0, 0, 0};
  for (const auto& j : Humanoid3dJoints()) {
    if (j.type == JointType::kSpherical) {
      values.insert(values.end(), {1, 0, 0, 0});
    } else {
      values.push_back(0);
    }
  }
  return values;
}

std::string DeepMimicText(const std::vector<std::vector<double>>& frames) {
  std::ostringstream out;
  out << std::setprecision(17) << "{\"Loop\": \"wrap\", \"Frames\": [";
  for (size_t f = 0; f < frames.size(); ++f) {
    out << (f ? ",\n" : "\n") << "[";
    for (size_t i = 0; i < frames[f].size(); ++i) out << (i ? ", " : "") << frames[f][i];
    out << "]";
  }
  out << "]}";
  return out.str();
}

TEST(DeepMimicFormat, ConvertsYUpToZUp) {
  // (x, y, z) -> (x, -z, y) for positions and quaternion axes.
  ExpectVecNear(FromYUp(Vec3{1, 2, 3}), {1, -3, 2}, 0, "vector");
  ExpectQuatNear(FromYUp(Quat{0.5, 0.1, 0.2, 0.3}), {0.5, 0.1, -0.3, 0.2}, 0, "quaternion");
  // A quarter turn about Y-up's vertical (+y) is a quarter turn about +z here.
  ExpectQuatNear(FromYUp(AxisAngle({0, 1, 0}, M_PI / 2)), AxisAngle({0, 0, 1}, M_PI / 2), 1e-15,
                 "yaw");
  // Converting then rotating equals rotating then converting.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Quat q = Normalized({u(rng), u(rng), u(rng), u(rng)});
    Vec3 v = {u(rng), u(rng), u(rng)};
    ExpectVecNear(Rotate(FromYUp(q), FromYUp(v)), FromYUp(Rotate(q, v)), 1e-12, "rotate");
  }
}

TEST(DeepMimicFormat, ParsesFramesIntoZUpPoses) {
  std::vector<double> first = DeepMimicRestFrame(0.25);
  std::vector<double> second = DeepMimicRestFrame(0.25);
  // Root at (1, 2, 3) Y-up = (1, -3, 2) Z-up, turned 90 degrees about the vertical.
  first[1] = 1, first[2] = 2, first[3] = 3;
  first[4] = std::cos(M_PI / 4), first[5] = 0, first[6] = std::sin(M_PI / 4), first[7] = 0;
  // The right knee bends 0.5 rad about DeepMimic's +z, which is -y here.
  first[DeepMimicIndex("right_knee")] = 0.5;
  // The neck turns 0.6 rad about DeepMimic's +z: (cos 0.3, 0, 0, sin 0.3) -> (cos 0.3, 0,
  // -sin 0.3, 0).
  int neck = DeepMimicIndex("neck");
  first[neck] = std::cos(0.3), first[neck + 3] = std::sin(0.3);
  // The next frame 1 m further along x and 2 m along DeepMimic's z (-2 m along y here).
  second[1] = 2, second[2] = 2, second[3] = 5;
  MotionClip clip = ParseMotion(DeepMimicText({first, second}), "/data/two_frames.txt");
  EXPECT_EQ(clip.name(), "two_frames");
  EXPECT_TRUE(clip.loop());
  EXPECT_EQ(clip.num_frames(), 2);
  EXPECT_DOUBLE_EQ(clip.duration(), 0.25);
  ExpectVecNear(clip.frame(0).root_position, {1, -3, 2}, 0, "root position");
  ExpectQuatNear(clip.frame(0).root_rotation, AxisAngle({0, 0, 1}, M_PI / 2), 1e-15,
                 "root rotation");
  ExpectQuatNear(clip.frame(0).joint_rotations[3], AxisAngle({0, -1, 0}, 0.5), 1e-15, "knee");
  ExpectQuatNear(clip.frame(0).joint_rotations[1], {std::cos(0.3), 0, -std::sin(0.3), 0}, 1e-15,
                 "neck");
  ExpectQuatNear(clip.frame(0).joint_rotations[0], kIdentityQuat, 0, "chest");
  // (1, -3, 2) to (2, -5, 2): horizontal displacement (1, -2, 0).
  ExpectVecNear(clip.cycle_displacement(), {1, -2, 0}, 1e-15, "displacement");
}

TEST(DeepMimicFormat, RejectsMalformedFramesNamingFrameAndField) {
  std::vector<double> rest = DeepMimicRestFrame(0.1);

  std::vector<double> short_frame = rest;
  short_frame.pop_back();
  EXPECT_THAT(ParseError(DeepMimicText({rest, short_frame}), "bad.txt"),
              HasSubstr("bad.txt: frame 1: expected 44 values per frame, got 43"));

  std::vector<double> zero = rest;
  for (int k = 0; k < 4; ++k) zero[DeepMimicIndex("left_hip") + k] = 0;
  EXPECT_THAT(ParseError(DeepMimicText({rest, zero, rest}), "bad.txt"),
              HasSubstr("bad.txt: frame 1: left_hip: quaternion norm 0.000000 is too far from 1"));
  std::vector<double> scaled = rest;
  scaled[4] = 1.6;  // root rotation (1.6, 0, 0, 0)
  EXPECT_THAT(ParseError(DeepMimicText({scaled, rest}), "bad.txt"),
              HasSubstr("bad.txt: frame 0: root rotation: quaternion norm 1.600000 is too far"));

  std::vector<double> still = rest;
  still[0] = 0;
  EXPECT_THAT(ParseError(DeepMimicText({still, rest}), "bad.txt"),
              HasSubstr("bad.txt: frame 0: duration must be positive"));
  std::vector<double> backwards = rest;
  backwards[0] = -0.1;
  EXPECT_THAT(ParseError(DeepMimicText({rest, backwards, rest}), "bad.txt"),
              HasSubstr("bad.txt: frame 1: duration must be positive"));

  // A value that is not a number: the right knee of frame 1.
  std::vector<double> marked = rest;
  marked[DeepMimicIndex("right_knee")] = 12345;
  std::string text = Replace(DeepMimicText({rest, marked}), "12345", "\"bent\"");
  EXPECT_THAT(ParseError(text, "bad.txt"),
              HasSubstr("bad.txt: frame 1: right_knee: expected a number, got \"bent\""));

  EXPECT_THAT(ParseError(DeepMimicText({rest}), "bad.txt"),
              HasSubstr("bad.txt: a clip needs at least two frames, got 1"));
  EXPECT_THAT(ParseError(Replace(DeepMimicText({rest, rest}), "wrap", "forever"), "bad.txt"),
              HasSubstr("bad.txt: Loop: expected \"wrap\" or \"none\""));
  EXPECT_THAT(ParseError(R"({"Loop": "none", "Frames": 3})", "bad.txt"),
              HasSubstr("bad.txt: Frames: expected a list of frames"));
}

// --- the project's format ---

// Two frames half a second apart animating the neck and the right knee.
const char* kTinyClip = R"({
  "format": "ragdoll-clip",
  "version": 1,
  "name": "tiny",
  "loop": false,
  "frame_duration": 0.5,
  "joints": ["neck", "right_knee"],
  "frames": [
    {"root_position": [0, 0, 1], "root_rotation": [1, 0, 0, 0], "rotations": [[1, 0, 0, 0], [1, 0, 0, 0]]},
    {"root_position": [0.5, 0, 1], "root_rotation": [1, 0, 0, 0], "rotations": [[0.6, 0.8, 0, 0], [0.8, 0, 0.6, 0]]}
  ]
})";

TEST(ProjectFormat, ParsesAClip) {
  MotionClip clip = ParseMotion(kTinyClip, "tiny.json");
  EXPECT_EQ(clip.name(), "tiny");
  EXPECT_FALSE(clip.loop());
  EXPECT_EQ(clip.num_frames(), 2);
  EXPECT_DOUBLE_EQ(clip.duration(), 0.5);
  ExpectVecNear(clip.frame(1).root_position, {0.5, 0, 1}, 0, "root position");
  ExpectQuatNear(clip.frame(1).joint_rotations[1], {0.6, 0.8, 0, 0}, 1e-15, "neck");
  ExpectQuatNear(clip.frame(1).joint_rotations[3], {0.8, 0, 0.6, 0}, 1e-15, "right knee");
  // Joints the file leaves out rest at identity.
  ExpectQuatNear(clip.frame(1).joint_rotations[0], kIdentityQuat, 0, "chest");
  ExpectQuatNear(clip.frame(1).joint_rotations[11], kIdentityQuat, 0, "left elbow");
}

TEST(ProjectFormat, RejectsMalformedClipsNamingFileFrameAndField) {
  const std::string tiny = kTinyClip;
  EXPECT_THAT(ParseError(Replace(tiny, "\"right_knee\"]", "\"left_foot\"]"), "tiny.json"),
              HasSubstr("tiny.json: joints: unknown joint 'left_foot'"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"right_knee\"]", "\"neck\"]"), "tiny.json"),
              HasSubstr("tiny.json: joints: 'neck' is listed twice"));
  EXPECT_THAT(ParseError(Replace(tiny, "[0.5, 0, 1]", "[0.5, \"up\", 1]"), "tiny.json"),
              HasSubstr("tiny.json: frame 1: root_position: expected a number, got \"up\""));
  EXPECT_THAT(ParseError(Replace(tiny, "[0.6, 0.8, 0, 0]", "[0.6, 0.8, null, 0]"), "tiny.json"),
              HasSubstr("tiny.json: frame 1: rotations: neck: expected a number, got null"));
  EXPECT_THAT(ParseError(Replace(tiny, "[0.8, 0, 0.6, 0]", "[0.8, 0, 0.6]"), "tiny.json"),
              HasSubstr("tiny.json: frame 1: rotations: right_knee: expected 4 numbers"));
  EXPECT_THAT(ParseError(Replace(tiny, "[0.6, 0.8, 0, 0]", "[0, 0, 0, 0]"), "tiny.json"),
              HasSubstr("tiny.json: frame 1: neck: quaternion norm 0.000000 is too far from 1"));
  EXPECT_THAT(
      ParseError(Replace(tiny, "\"frame_duration\": 0.5", "\"frame_duration\": 0"), "tiny.json"),
      HasSubstr("tiny.json: frame_duration: must be positive"));
  EXPECT_THAT(
      ParseError(Replace(tiny, "\"frame_duration\": 0.5", "\"frame_duration\": -0.5"), "tiny.json"),
      HasSubstr("tiny.json: frame_duration: must be positive"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"frame_duration\": 0.5", "\"frame_duration\": \"fast\""),
                         "tiny.json"),
              HasSubstr("tiny.json: frame_duration: expected a number, got \"fast\""));
  // Missing fields.
  EXPECT_THAT(ParseError(Replace(tiny, "\"frame_duration\": 0.5,", ""), "tiny.json"),
              HasSubstr("tiny.json: frame_duration: missing"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"loop\": false,", ""), "tiny.json"),
              HasSubstr("tiny.json: loop: expected true/false"));
  EXPECT_THAT(
      ParseError(Replace(tiny, "[0.5, 0, 1], \"root_rotation\": [1, 0, 0, 0],", "[0.5, 0, 1],"),
                 "tiny.json"),
      HasSubstr("tiny.json: frame 1: root_rotation: expected 4 numbers, got null"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"rotations\": [[1, 0, 0, 0], [1, 0, 0, 0]]",
                                 "\"rotations\": [[1, 0, 0, 0]]"),
                         "tiny.json"),
              HasSubstr("tiny.json: frame 0: rotations: expected 2 quaternions"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"joints\": [\"neck\", \"right_knee\"],", ""), "tiny.json"),
              HasSubstr("tiny.json: joints: expected a list of joint names"));
  // Unknown fields, wrong format or version.
  EXPECT_THAT(
      ParseError(Replace(tiny, "\"loop\": false,", "\"loop\": false, \"fps\": 30,"), "tiny.json"),
      HasSubstr("tiny.json: unknown field 'fps'"));
  EXPECT_THAT(ParseError(Replace(tiny, "{\"root_position\": [0, 0, 1],",
                                 "{\"time\": 0, \"root_position\": [0, 0, 1],"),
                         "tiny.json"),
              HasSubstr("tiny.json: frame 0: unknown field 'time'"));
  EXPECT_THAT(ParseError(Replace(tiny, "\"ragdoll-clip\"", "\"bvh\""), "tiny.json"),
              HasSubstr("tiny.json: format: expected \"ragdoll-clip\""));
  EXPECT_THAT(ParseError(Replace(tiny, "\"version\": 1", "\"version\": 2"), "tiny.json"),
              HasSubstr("tiny.json: version: this build reads version 1"));
  EXPECT_THAT(ParseError(tiny.substr(0, 100), "tiny.json"), HasSubstr("tiny.json: not valid JSON"));
  EXPECT_THAT(ParseError("[1, 2]", "tiny.json"), HasSubstr("tiny.json: expected a JSON object"));
}

// nlohmann's own type_error ("type must be string, but is number") would name neither the file
// nor the field.
TEST(ProjectFormat, AFormatFieldOfTheWrongTypeIsAConfigError) {
  const std::string tiny = kTinyClip;
  EXPECT_THAT(ParseError(Replace(tiny, "\"ragdoll-clip\"", "1"), "tiny.json"),
              HasSubstr("tiny.json: format"));
}

// Found by fuzz_motion: a number beyond double's range made nlohmann throw out_of_range, which
// is not a ConfigError, so callers that catch ConfigError let it through.
TEST(ProjectFormat, ANumberOutOfRangeIsAConfigError) {
  const std::string tiny = kTinyClip;
  EXPECT_THAT(
      ParseError(Replace(tiny, "\"ragdoll-clip\"", "0.9e8079"), "tiny.json"),
      HasSubstr("tiny.json: not valid JSON: [json.exception.out_of_range.406] number overflow"));
  EXPECT_THAT(ParseError("{\"Frames\": [[1e400]]}", "big.txt"),
              HasSubstr("big.txt: not valid JSON"));
}

// A folder of its own under the system's temporary directory, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("ragdoll_" + std::string(test->test_suite_name()) + "_" + test->name() + "_" +
             std::to_string(::getpid()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

TEST(LoadMotion, NamesAnUnreadableOrBadFile) {
  EXPECT_THAT(ConfigErrorOf([] { LoadMotion("/nonexistent/clips/walk.json"); }),
              HasSubstr("/nonexistent/clips/walk.json: cannot open motion file"));
  TempDir dir;
  std::string path = dir / "bad.json";
  std::ofstream(path) << Replace(kTinyClip, "\"right_knee\"]", "\"left_foot\"]");
  EXPECT_THAT(ConfigErrorOf([&] { LoadMotion(path); }),
              HasSubstr(path + ": joints: unknown joint 'left_foot'"));
}

TEST(ProjectFormat, RoundTripsTheDeepMimicWalk) {
  MotionClip walk = LoadDeepMimic("walk");
  // The project format stores one frame duration; DeepMimic's walk has 0.033332 s throughout.
  for (int i = 0; i + 1 < walk.num_frames(); ++i) ASSERT_EQ(walk.frame_duration(i), 0.033332);
  std::string text = FormatClip(walk, "DeepMimic humanoid3d walk");
  MotionClip back = ParseMotion(text, "walk.json");
  EXPECT_EQ(back.name(), "humanoid3d_walk");
  EXPECT_TRUE(back.loop());
  ASSERT_EQ(back.num_frames(), walk.num_frames());
  EXPECT_EQ(back.frame_duration(0), 0.033332);
  EXPECT_NEAR(back.duration(), walk.duration(), 1e-12);
  ExpectVecNear(back.cycle_displacement(), walk.cycle_displacement(), 1e-6, "displacement");
  // Six decimals: within 5e-7 plus the renormalisation of the rounded quaternions.
  for (int i = 0; i < walk.num_frames(); ++i) {
    ExpectPoseNear(back.frame(i), walk.frame(i), 1e-6, "frame " + std::to_string(i));
  }

  // Through a file too.
  TempDir dir;
  SaveClip(walk, "DeepMimic humanoid3d walk", dir / "walk.json");
  MotionClip loaded = LoadMotion(dir / "walk.json");
  ASSERT_EQ(loaded.num_frames(), walk.num_frames());
  ExpectPoseNear(loaded.frame(20), walk.frame(20), 1e-6, "saved frame 20");
}

TEST(ProjectFormat, NeedsEvenlySpacedFrames) {
  MotionClip uneven("uneven", false, {0.1, 0.2, 0},
                    {RestPose({0, 0, 1}), RestPose({0, 0, 1}), RestPose({0, 0, 1})});
  EXPECT_THROW(FormatClip(uneven, ""), std::invalid_argument);
}

TEST(AssetMotions, AllLoad) {
  const std::filesystem::path folder = kAssets + "/motions";
  std::vector<std::filesystem::path> files;
  if (std::filesystem::is_directory(folder)) {
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      if (entry.path().extension() == ".json") files.push_back(entry.path());
    }
  }
  if (files.empty()) GTEST_SKIP() << "no clips in " << folder << " yet";
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    try {
      MotionClip clip = LoadMotion(file.string());
      EXPECT_GE(clip.num_frames(), 2) << file;
      EXPECT_GT(clip.duration(), 0) << file;
      if (clip.loop()) {
        // A looping clip's last frame is its first pose, moved on horizontally and turned about
        // the vertical by one cycle (motion_clip.h); otherwise the reference jumps at every
        // cycle boundary.
        const Pose& first = clip.frame(0);
        const Pose& last = clip.frame(clip.num_frames() - 1);
        EXPECT_NEAR(last.root_position[2], first.root_position[2], 1e-6) << file;
        Quat turned = Multiply(AxisAngle({0, 0, 1}, clip.cycle_yaw()), first.root_rotation);
        EXPECT_LT(AngleBetween(last.root_rotation, turned), 0.01) << file;
        for (size_t j = 0; j < first.joint_rotations.size(); ++j) {
          EXPECT_LT(AngleBetween(last.joint_rotations[j], first.joint_rotations[j]), 0.01)
              << file << " " << Humanoid3dJoints()[j].name;
        }
      }
      std::cout << file.filename().string() << ": " << clip.num_frames() << " frames, "
                << clip.duration() << " s" << (clip.loop() ? ", loops" : "") << "\n";
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

// --- the DeepMimic walk on this project's humanoid ---

TEST(DeepMimicWalkOnHumanoid, FeetTouchTheFloorWithoutSinking) {
  auto character = Character::Load(kAssets + "/character/humanoid.xml");
  const mjModel* m = character->model();
  DataPtr d = character->MakeData();
  const char* names[2] = {"right_ankle", "left_ankle"};
  int feet[2];
  for (int s = 0; s < 2; ++s) {
    feet[s] = mj_name2id(m, mjOBJ_GEOM, names[s]);
    ASSERT_GE(feet[s], 0) << names[s];
    ASSERT_EQ(m->geom_type[feet[s]], mjGEOM_BOX) << names[s];
  }
  MotionClip walk = LoadDeepMimic("walk");
  double lowest_of_lower = 1e9, highest_of_lower = -1e9;  // over frames, of the lower foot
  double foot_min[2] = {1e9, 1e9};
  int lowest_frame = -1, highest_frame = -1;
  for (int i = 0; i < walk.num_frames(); ++i) {
    character->PoseToQpos(walk.frame(i), d->qpos);
    mj_kinematics(m, d.get());
    double height[2];
    for (int s = 0; s < 2; ++s) {
      height[s] = GeomLowestPoint(m, d.get(), feet[s]);
      foot_min[s] = std::min(foot_min[s], height[s]);
    }
    double lower = std::min(height[0], height[1]);
    if (lower < lowest_of_lower) {
      lowest_of_lower = lower;
      lowest_frame = i;
    }
    if (lower > highest_of_lower) {
      highest_of_lower = lower;
      highest_frame = i;
    }
    EXPECT_LT(lower, 0.05) << "frame " << i << ": both feet in the air (right " << height[0]
                           << " m, left " << height[1] << " m)";
  }
  std::cout << "DeepMimic walk on humanoid.xml, lower foot's lowest point: min " << lowest_of_lower
            << " m (frame " << lowest_frame << "), max " << highest_of_lower << " m (frame "
            << highest_frame << "); right foot min " << foot_min[0] << " m, left foot min "
            << foot_min[1] << " m\n";
  RecordProperty("lower_foot_min_m", std::to_string(lowest_of_lower));
  RecordProperty("lower_foot_max_m", std::to_string(highest_of_lower));
  // Touches the floor (z = 0) without sinking more than 3 cm into it.
  EXPECT_GE(lowest_of_lower, -0.03);
  EXPECT_LE(lowest_of_lower, 0.03);
}

}  // namespace
}  // namespace ragdoll::character
