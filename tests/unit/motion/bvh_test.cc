#include "motion/bvh.h"

#include <gtest/gtest.h>

#include <string>

#include "common/config_section.h"

namespace ragdoll::motion {

using character::AxisAngle;
using character::Multiply;
using character::Rotate;
using character::Vec3;

namespace {

// A root with 6 channels (positions then Z X Y rotations), a child with a different rotation
// order, an end site; CRLF line endings and tabs, as Windows tools write them.
const char* kSmall =
    "HIERARCHY\r\n"
    "ROOT Hips\r\n"
    "{\r\n"
    "\tOFFSET 0.0 0.0 0.0\r\n"
    "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\r\n"
    "\tJOINT LeftUpLeg\r\n"
    "\t{\r\n"
    "\t\tOFFSET 10 -5 0\r\n"
    "\t\tCHANNELS 3 Xrotation Yrotation Zrotation\r\n"
    "\t\tEnd Site\r\n"
    "\t\t{\r\n"
    "\t\t\tOFFSET 0 -40 0\r\n"
    "\t\t}\r\n"
    "\t}\r\n"
    "}\r\n"
    "MOTION\r\n"
    "Frames: 2\r\n"
    "Frame Time: 0.0333333\r\n"
    "1 90 3 90 90 0 0 0 0\r\n"
    "1 91 3 0 0 0 45 0 0\r\n";

void ExpectNear(const Vec3& a, const Vec3& b) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 1e-9) << i;
}

TEST(Bvh, ParsesHierarchyChannelsAndFrames) {
  BvhMotion m = ParseBvh(kSmall, "small.bvh");
  ASSERT_EQ(m.joints.size(), 3u);
  EXPECT_EQ(m.joints[0].name, "Hips");
  EXPECT_EQ(m.joints[0].parent, -1);
  EXPECT_EQ(m.joints[1].name, "LeftUpLeg");
  EXPECT_EQ(m.joints[1].parent, 0);
  EXPECT_EQ(m.joints[1].first_channel, 6);
  EXPECT_TRUE(m.joints[2].end_site);
  EXPECT_EQ(m.joints[2].name, "LeftUpLeg_end");
  EXPECT_EQ(m.joints[2].parent, 1);
  ExpectNear(m.joints[2].offset, {0, -40, 0});
  EXPECT_EQ(m.channel_count, 9);
  EXPECT_EQ(m.num_frames(), 2);
  EXPECT_DOUBLE_EQ(m.frame_time, 0.0333333);
  EXPECT_EQ(m.Find("LeftUpLeg"), 1);
  EXPECT_EQ(m.Find("LeftUpLeg_end"), -1);  // end sites are not joints
  ExpectNear(m.LocalTranslation(0, 0), {1, 90, 3});
  ExpectNear(m.LocalTranslation(1, 1), {10, -5, 0});  // no position channels: the offset
}

TEST(Bvh, RotationChannelsComposeInFileOrder) {
  BvhMotion m = ParseBvh(kSmall, "small.bvh");
  // Root, frame 0: Zrotation 90 then Xrotation 90, R = Rz(90) Rx(90).
  // Rx(90) takes +z to -y, Rz(90) takes -y to +x.
  ExpectNear(Rotate(m.LocalRotation(0, 0), {0, 0, 1}), {1, 0, 0});
  // The other order (Rx Rz) would leave +z at -y.
  ExpectNear(
      Rotate(Multiply(AxisAngle({1, 0, 0}, M_PI / 2), AxisAngle({0, 0, 1}, M_PI / 2)), {0, 0, 1}),
      {0, -1, 0});
  // Child, frame 1: Xrotation 45 only.
  ExpectNear(Rotate(m.LocalRotation(1, 1), {0, 1, 0}), {0, std::sqrt(0.5), std::sqrt(0.5)});
  // End sites carry no channels: identity.
  ExpectNear(Rotate(m.LocalRotation(1, 2), {0, 1, 0}), {0, 1, 0});
}

// The error names the file and line, and says what is wrong.
void ExpectRejected(const std::string& text, const std::string& where, const std::string& why) {
  try {
    ParseBvh(text, "bad.bvh");
    FAIL() << "accepted; expected " << where << " " << why;
  } catch (const ConfigError& e) {
    std::string message = e.what();
    EXPECT_NE(message.find("bad.bvh:" + where + ":"), std::string::npos) << message;
    EXPECT_NE(message.find(why), std::string::npos) << message;
  }
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

TEST(Bvh, RejectsMalformedFilesWithFileLineAndReason) {
  const std::string good = kSmall;
  ExpectRejected(Replace(good, "HIERARCHY", "HIERARCHIE"), "1", "starts with HIERARCHY");
  ExpectRejected(Replace(good, "\tJOINT LeftUpLeg", "\tJIONT LeftUpLeg"), "6",
                 "expected JOINT, End Site or '}'");
  ExpectRejected(Replace(good, "OFFSET 10 -5 0", "OFFSET 10 -5"), "9",
                 "OFFSET of 'LeftUpLeg' (3 numbers): 'CHANNELS' is not a finite number");
  ExpectRejected(Replace(good, "CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 7 Xrotation"),
                 "9", "CHANNELS count must be 0 to 6");
  ExpectRejected(Replace(good, "CHANNELS 3 Xrotation Yrotation Zrotation", "CHANNELS 3 Xrotation"),
                 "10", "declares 3 channels but lists 1");
  ExpectRejected(Replace(good, "Yrotation Zrotation", "Yrotation Wrotation"), "9",
                 "unknown channel 'Wrotation'");
  ExpectRejected(Replace(good, "\t}\r\n}\r\nMOTION", "\t}\r\nMOTION"), "14",
                 "unexpected end of the hierarchy");
  ExpectRejected(Replace(good, "1 91 3 0 0 0 45 0 0", "1 91 3 0 0 0 45 0"), "20",
                 "frame 1 has 8 values; the hierarchy declares 9 channels");
  ExpectRejected(Replace(good, "1 91 3 0 0 0 45 0 0", "1 91 3 0 0 0 4x5 0 0"), "20",
                 "frame 1: '4x5' is not a finite number");
  ExpectRejected(Replace(good, "1 91 3 0 0 0 45 0 0", "1 91 3 0 0 0 nan 0 0"), "20",
                 "is not a finite number");
  ExpectRejected(Replace(good, "1 91 3 0 0 0 45 0 0\r\n", ""), "19",
                 "truncated: 'Frames: 2' but 1 frame lines");
  ExpectRejected(Replace(good, "Frames: 2", "Frames: two"), "17", "positive whole number");
  ExpectRejected(Replace(good, "Frame Time: 0.0333333", "Frame Time: 0"), "18",
                 "positive number of seconds");
  ExpectRejected(Replace(good, "MOTION", "MOTIONS"), "20", "no MOTION section");
  ExpectRejected(Replace(good, "JOINT LeftUpLeg", "JOINT Hips"), "6", "used twice");
}

// Real files miscount their frames: the declared ones are read and the extra lines reported.
TEST(Bvh, LinesBeyondTheDeclaredFramesAreIgnoredWithANote) {
  const std::string good = kSmall;
  BvhMotion m = ParseBvh(Replace(good, "Frames: 2", "Frames: 1"), "short.bvh");
  EXPECT_EQ(m.num_frames(), 1);
  ASSERT_EQ(m.notes.size(), 1u);
  EXPECT_EQ(m.notes[0], "short.bvh:20: 1 line after the 1 frames 'Frames:' declares: ignored");
  EXPECT_TRUE(ParseBvh(good, "small.bvh").notes.empty());
}

TEST(Bvh, AMissingFileIsAConfigError) {
  EXPECT_THROW(LoadBvh("/nonexistent/file.bvh"), ConfigError);
}

}  // namespace
}  // namespace ragdoll::motion
