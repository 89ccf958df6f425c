#include "motion/retarget.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "character/motion_io.h"
#include "character/skeleton.h"
#include "common/config_section.h"

namespace ragdoll::motion {

using character::AngleBetween;
using character::Character;
using character::FindJoint;
using character::LoadMotion;
using character::MotionClip;
using character::Multiply;
using character::Pose;
using character::Quat;
using character::Rotate;
using character::Vec3;

namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

MotionClip RetargetFromBvh(const BvhMotion& bvh, const JointMapping& mapping,
                           const Character& character, const ImportOptions& options,
                           std::vector<std::string>* warnings = nullptr) {
  return Retarget(FromBvh(bvh), mapping, character, options, warnings);
}

class RetargetTest : public ::testing::Test {
 protected:
  RetargetTest()
      : character_(Character::Load(kAssets + "/character/humanoid.xml")),
        walk_(LoadMotion(kAssets + "/motions/walk.json")),
        squat_(LoadMotion(kAssets + "/motions/squat.json")) {}

  // Exports `clip` as BVH text with `naming`, parses it back and imports it with `mapping`.
  MotionClip RoundTrip(const MotionClip& clip, const std::string& naming,
                       const ExportOptions& export_options, ImportOptions import_options = {}) {
    import_options.feet = ImportOptions::Feet::kRest;  // our own files: the rest pose is exact
    BvhMotion written = ClipToBvh(clip, *character_, ReadJointMapping(naming), export_options);
    BvhMotion read = ParseBvh(FormatBvh(written), "clip.bvh");
    return RetargetFromBvh(read, ReadJointMapping(naming), *character_, import_options);
  }

  // Largest joint-rotation difference (radians) and root-position difference (metres, after
  // removing each clip's own floor offset) over all frames.
  void Compare(const MotionClip& a, const MotionClip& b, double* rotation, double* position) {
    ASSERT_EQ(a.num_frames(), b.num_frames());
    double floor_a = INFINITY, floor_b = INFINITY;
    for (int f = 0; f < a.num_frames(); ++f) {
      floor_a = std::min(floor_a, character_->LowestPoint(a.frame(f)));
      floor_b = std::min(floor_b, character_->LowestPoint(b.frame(f)));
    }
    *rotation = *position = 0;
    for (int f = 0; f < a.num_frames(); ++f) {
      const Pose &pa = a.frame(f), &pb = b.frame(f);
      *rotation = std::max(*rotation, AngleBetween(pa.root_rotation, pb.root_rotation));
      for (size_t j = 0; j < pa.joint_rotations.size(); ++j) {
        *rotation = std::max(*rotation, AngleBetween(pa.joint_rotations[j], pb.joint_rotations[j]));
      }
      Vec3 da = pa.root_position, db = pb.root_position;
      da[0] -= a.frame(0).root_position[0];
      da[1] -= a.frame(0).root_position[1];
      da[2] -= floor_a;
      db[0] -= b.frame(0).root_position[0];
      db[1] -= b.frame(0).root_position[1];
      db[2] -= floor_b;
      for (int i = 0; i < 3; ++i) *position = std::max(*position, std::abs(da[i] - db[i]));
    }
  }

  std::shared_ptr<const Character> character_;
  MotionClip walk_, squat_;
};

TEST_F(RetargetTest, ExportThenImportReproducesTheClip) {
  for (const MotionClip* clip : {&walk_, &squat_}) {
    ExportOptions cmu_like;
    cmu_like.y_up = true;
    cmu_like.units_per_metre = 100;
    ImportOptions import_options;
    import_options.loop = clip->loop();
    MotionClip back = RoundTrip(*clip, "cmu", cmu_like, import_options);
    double rotation, position;
    Compare(*clip, back, &rotation, &position);
    EXPECT_LT(rotation, 1e-3) << clip->name();  // radians; the file keeps 6 decimals of degrees
    EXPECT_LT(position, 1e-4) << clip->name();  // metres
    EXPECT_NEAR(back.duration(), clip->duration(), 1e-6);
    EXPECT_EQ(back.loop(), clip->loop());
  }
}

// A capture whose foot rest pose is not the foot flat on the floor (the toe joint sits lower
// than the ankle's bone suggests, as in marker-based captures): aligned from the rest pose, the
// character walks on its toes; levelled on the planted frames, its feet are as in the original.
TEST_F(RetargetTest, FeetAreLevelledOnThePlantedFrames) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  const double tilt = 25 * M_PI / 180;
  for (const char* toe : {"right_toe", "left_toe"}) {
    BvhJoint& j = bvh.joints[bvh.Find(toe)];
    const double length = std::hypot(j.offset[0], j.offset[2]);
    j.offset = {length * std::cos(tilt), j.offset[1], -length * std::sin(tilt)};
  }
  ImportOptions rest, floor;
  rest.feet = ImportOptions::Feet::kRest;
  floor.feet = ImportOptions::Feet::kFloor;
  std::vector<std::string> notes;
  MotionClip from_rest = RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, rest);
  MotionClip levelled =
      RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, floor, &notes);
  double rest_error = 0, floor_error = 0;
  for (const char* ankle : {"right_ankle", "left_ankle"}) {
    const int a = FindJoint(ankle);
    for (int f = 0; f < walk_.num_frames(); ++f) {
      rest_error = std::max(rest_error, AngleBetween(from_rest.frame(f).joint_rotations[a],
                                                     walk_.frame(f).joint_rotations[a]));
      floor_error = std::max(floor_error, AngleBetween(levelled.frame(f).joint_rotations[a],
                                                       walk_.frame(f).joint_rotations[a]));
    }
  }
  EXPECT_NEAR(rest_error, tilt, 0.02);  // the whole tilt, in every frame
  EXPECT_LT(floor_error, 0.03);         // within the original's own planted-foot pitch
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("right_foot: levelled on its"), std::string::npos) << notes[0];
  // The original's planted feet are nearly level already: levelling moves them little.
  std::vector<std::string> own;
  BvhMotion plain = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  MotionClip own_levelled =
      RetargetFromBvh(plain, ReadJointMapping("ragdoll"), *character_, floor, &own);
  double own_error = 0;
  for (int f = 0; f < walk_.num_frames(); ++f) {
    own_error = std::max(
        own_error, AngleBetween(own_levelled.frame(f).joint_rotations[FindJoint("left_ankle")],
                                walk_.frame(f).joint_rotations[FindJoint("left_ankle")]));
  }
  EXPECT_LT(own_error, 0.03);
}

TEST_F(RetargetTest, ChannelOrderUnitsAndUpAxisDoNotChangeTheImport) {
  const MotionClip reference = RoundTrip(walk_, "ragdoll", {"ZXY", 1, false});
  for (const ExportOptions& variant :
       {ExportOptions{"XYZ", 100, true}, ExportOptions{"YXZ", 1, true},
        ExportOptions{"ZYX", 2.54, false}}) {
    MotionClip other = RoundTrip(walk_, "ragdoll", variant);
    double rotation, position;
    Compare(reference, other, &rotation, &position);
    EXPECT_LT(rotation, 1e-3) << variant.rotation_order;
    EXPECT_LT(position, 1e-4) << variant.rotation_order;
  }
}

TEST_F(RetargetTest, MirrorSwapsLeftAndRight) {
  ImportOptions mirror;
  mirror.mirror = true;
  MotionClip mirrored = RoundTrip(walk_, "ragdoll", {}, mirror);
  MotionClip plain = RoundTrip(walk_, "ragdoll", {});
  const int right_knee = FindJoint("right_knee"), left_knee = FindJoint("left_knee");
  for (int f = 0; f < plain.num_frames(); f += 5) {
    EXPECT_LT(AngleBetween(mirrored.frame(f).joint_rotations[left_knee],
                           plain.frame(f).joint_rotations[right_knee]),
              1e-3)
        << f;
    // Sideways sway changes sign; forward travel does not.
    EXPECT_NEAR(mirrored.frame(f).root_position[1], -plain.frame(f).root_position[1], 1e-4);
    EXPECT_NEAR(mirrored.frame(f).root_position[0], plain.frame(f).root_position[0], 1e-4);
  }
}

TEST_F(RetargetTest, TrimsAndResamples) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  ImportOptions trim;
  trim.first_frame = 3;
  trim.last_frame = 12;
  MotionClip trimmed = RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, trim);
  EXPECT_EQ(trimmed.num_frames(), 10);
  EXPECT_NEAR(trimmed.duration(), 9 * bvh.frame_time, 1e-9);
  ImportOptions resample;
  resample.fps = 2 / bvh.frame_time;  // twice the file's rate
  MotionClip fine = RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, resample);
  EXPECT_EQ(fine.num_frames(), 2 * bvh.num_frames() - 1);
  EXPECT_NEAR(fine.duration(), (bvh.num_frames() - 1) * bvh.frame_time, 1e-9);
  trim.last_frame = 3;  // one frame is not a clip
  EXPECT_THROW(RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, trim), ConfigError);
}

// A T-posed source (arms straight out sideways at rest, every rotation zero) must put the
// character's arms out sideways, not along its rest (hanging) direction.
TEST_F(RetargetTest, AlignsATPosedSkeletonToTheCharacter) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  for (auto& frame : bvh.frames) {
    for (size_t c = 3; c < frame.size(); ++c) frame[c] = 0;  // keep the root position only
  }
  for (auto& joint : bvh.joints) {
    const double side = joint.name.rfind("left_", 0) == 0 ? 1 : -1;
    if (joint.name == "right_elbow" || joint.name == "left_elbow")
      joint.offset = {0, side * 0.27, 0};
    if (joint.name == "right_wrist" || joint.name == "left_wrist") {
      joint.offset = {0, side * 0.26, 0};
    }
  }
  MotionClip clip = RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, {});
  const Pose& p = clip.frame(0);
  for (const char* side : {"right_", "left_"}) {
    Quat shoulder = Multiply(Multiply(p.root_rotation, p.joint_rotations[FindJoint("chest")]),
                             p.joint_rotations[FindJoint(std::string(side) + "shoulder")]);
    Vec3 arm = Rotate(shoulder, {0, 0, -1});  // the upper arm's rest direction
    const double expected = side[0] == 'l' ? 1 : -1;
    EXPECT_NEAR(arm[1], expected, 1e-6) << side;
    EXPECT_NEAR(p.joint_rotations[FindJoint(std::string(side) + "elbow")][0], 1, 1e-9);
  }
}

// A file whose rest is a posed frame (Blender's FBX of DeepMimic's run): the left shin level
// behind the knee and the foot pointing down, along the twist references the retarget uses for
// them (forward, up), while the character's shin hangs and its foot points forward.
TEST_F(RetargetTest, ARestPoseWithALevelShinStillAligns) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  for (auto& frame : bvh.frames) {
    for (size_t c = 3; c < frame.size(); ++c) frame[c] = 0;  // the rest pose in every frame
  }
  for (auto& joint : bvh.joints) {
    if (joint.name == "left_ankle") joint.offset = {-0.41, 0, 0};
    if (joint.name == "left_toe") joint.offset = {0, 0, -0.15};
  }
  ImportOptions options;
  options.feet = ImportOptions::Feet::kRest;
  MotionClip clip = RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, options);
  const Pose& p = clip.frame(0);
  for (const Quat& q : p.joint_rotations) {
    for (double c : q) ASSERT_TRUE(std::isfinite(c));
  }
  // The knee bent a quarter turn, the thigh still hanging.
  EXPECT_NEAR(AngleBetween(p.joint_rotations[FindJoint("left_knee")], {1, 0, 0, 0}), M_PI / 2,
              1e-6);
  EXPECT_NEAR(AngleBetween(p.joint_rotations[FindJoint("left_hip")], {1, 0, 0, 0}), 0, 1e-6);
}

TEST_F(RetargetTest, MixamoNamesMatchWithOrWithoutTheirNamespace) {
  BvhMotion bvh = ClipToBvh(squat_, *character_, ReadJointMapping("mixamo"), {});
  std::string text = FormatBvh(bvh);
  for (size_t at; (at = text.find("mixamorig:")) != std::string::npos;) text.erase(at, 10);
  MotionClip bare =
      RetargetFromBvh(ParseBvh(text, "bare.bvh"), ReadJointMapping("mixamo"), *character_, {});
  MotionClip full = RetargetFromBvh(bvh, ReadJointMapping("mixamo"), *character_, {});
  double rotation, position;
  Compare(bare, full, &rotation, &position);
  EXPECT_LT(rotation, 1e-6);
}

TEST_F(RetargetTest, ReportsMappingProblems) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  std::vector<std::string> warnings;
  RetargetFromBvh(bvh, ReadJointMapping("ragdoll"), *character_, {}, &warnings);
  for (const std::string& w : warnings)
    EXPECT_EQ(w.find("not in the file"), std::string::npos) << w;
  try {
    RetargetFromBvh(bvh, ReadJointMapping("cmu"), *character_, {});
    FAIL() << "imported with the wrong names";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("joint 'Hips' (mapped to root in"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ReadJointMapping("no_such_preset"), ConfigError);
  const std::string path = ::testing::TempDir() + "/typo_mapping.yaml";
  std::ofstream(path) << "root: Hips\nleft_kne: LeftLeg\n";
  try {
    ReadJointMapping(path);
    FAIL() << "accepted a misspelt part";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'left_knee'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ragdoll::motion
