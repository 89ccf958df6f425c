#include "actor/sim/retarget.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "actor/sim/motion_io.h"
#include "actor/sim/skeleton.h"
#include "common/config_section.h"

namespace ragdoll::sim {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

class RetargetTest : public ::testing::Test {
 protected:
  RetargetTest()
      : character_(Character::Load(kAssets + "/character/humanoid.xml")),
        walk_(LoadMotion(kAssets + "/motions/walk.json")),
        squat_(LoadMotion(kAssets + "/motions/squat.json")) {}

  // Exports `clip` as BVH text with `naming`, parses it back and imports it with `mapping`.
  MotionClip RoundTrip(const MotionClip& clip, const std::string& naming,
                       const ExportOptions& export_options, ImportOptions import_options = {}) {
    BvhMotion written = ClipToBvh(clip, *character_, ReadJointMapping(naming), export_options);
    BvhMotion read = ParseBvh(FormatBvh(written), "clip.bvh");
    return RetargetBvh(read, ReadJointMapping(naming), *character_, import_options);
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
  MotionClip trimmed = RetargetBvh(bvh, ReadJointMapping("ragdoll"), *character_, trim);
  EXPECT_EQ(trimmed.num_frames(), 10);
  EXPECT_NEAR(trimmed.duration(), 9 * bvh.frame_time, 1e-9);
  ImportOptions resample;
  resample.fps = 2 / bvh.frame_time;  // twice the file's rate
  MotionClip fine = RetargetBvh(bvh, ReadJointMapping("ragdoll"), *character_, resample);
  EXPECT_EQ(fine.num_frames(), 2 * bvh.num_frames() - 1);
  EXPECT_NEAR(fine.duration(), (bvh.num_frames() - 1) * bvh.frame_time, 1e-9);
  trim.last_frame = 3;  // one frame is not a clip
  EXPECT_THROW(RetargetBvh(bvh, ReadJointMapping("ragdoll"), *character_, trim), ConfigError);
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
    if (joint.name == "right_elbow_end" || joint.name == "left_elbow_end") {
      joint.offset = {0, side * 0.26, 0};
    }
  }
  MotionClip clip = RetargetBvh(bvh, ReadJointMapping("ragdoll"), *character_, {});
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

TEST_F(RetargetTest, MixamoNamesMatchWithOrWithoutTheirNamespace) {
  BvhMotion bvh = ClipToBvh(squat_, *character_, ReadJointMapping("mixamo"), {});
  std::string text = FormatBvh(bvh);
  for (size_t at; (at = text.find("mixamorig:")) != std::string::npos;) text.erase(at, 10);
  MotionClip bare =
      RetargetBvh(ParseBvh(text, "bare.bvh"), ReadJointMapping("mixamo"), *character_, {});
  MotionClip full = RetargetBvh(bvh, ReadJointMapping("mixamo"), *character_, {});
  double rotation, position;
  Compare(bare, full, &rotation, &position);
  EXPECT_LT(rotation, 1e-6);
}

TEST_F(RetargetTest, ReportsMappingProblems) {
  BvhMotion bvh = ClipToBvh(walk_, *character_, ReadJointMapping("ragdoll"), {});
  std::vector<std::string> warnings;
  RetargetBvh(bvh, ReadJointMapping("ragdoll"), *character_, {}, &warnings);
  EXPECT_TRUE(warnings.empty());
  try {
    RetargetBvh(bvh, ReadJointMapping("cmu"), *character_, {});
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
}  // namespace ragdoll::sim
