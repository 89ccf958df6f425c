#include "motion/auto_mapping.h"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "common/config_section.h"

namespace ragdoll::motion {

using character::kIdentityQuat;
using character::Vec3;

namespace {

// Rest positions of a T-posed humanoid, Y up, facing +Z (its left is +X), in centimetres, by
// role. Right-side roles mirror the left ones.
Vec3 RestPosition(const std::string& role) {
  static const std::map<std::string, Vec3> kLeft = {
      {"root", {0, 100, 0}},      {"lowspine", {0, 110, 0}}, {"spine", {0, 125, 0}},
      {"chest", {0, 140, 0}},     {"neck", {0, 155, 0}},     {"neck2", {0, 160, 0}},
      {"head", {0, 165, 0}},      {"headtop", {0, 180, 0}},  {"clavicle", {5, 150, 0}},
      {"upperarm", {18, 150, 0}}, {"forearm", {45, 150, 0}}, {"wrist", {70, 150, 0}},
      {"hand", {75, 150, 0}},     {"hipjoint", {5, 98, 0}},  {"thigh", {10, 95, 0}},
      {"calf", {10, 52, 0}},      {"foot", {10, 10, 0}},     {"toe", {10, 2, 12}},
      {"toeend", {10, 2, 18}}};
  if (role.rfind("r_", 0) == 0) {
    Vec3 p = kLeft.at(role.substr(2));
    return {-p[0], p[1], p[2]};
  }
  return kLeft.at(role.rfind("l_", 0) == 0 ? role.substr(2) : role);
}

// A skeleton from (name, parent name, role) rows, parents first, with two frames at rest.
SkeletonAnimation Skeleton(
    const std::vector<std::tuple<std::string, std::string, std::string>>& rows,
    bool mirror_geometry = false) {
  SkeletonAnimation s;
  s.origin = "test.fbx";
  s.frame_time = 1.0 / 30;
  std::map<std::string, int> index;
  for (const auto& [name, parent, role] : rows) {
    index[name] = static_cast<int>(s.joints.size());
    s.joints.push_back({name, parent.empty() ? -1 : index.at(parent), false});
    Vec3 p = RestPosition(role);
    if (mirror_geometry) p[0] = -p[0];
    s.rest.push_back({kIdentityQuat, p});
  }
  s.frames = {s.rest, s.rest};
  return s;
}

using Rows = std::vector<std::tuple<std::string, std::string, std::string>>;

// Rows for a rig whose names follow `name(role)`; `arms_under` and `legs_under` name the roles
// the limbs hang from.
Rows Rig(const std::map<std::string, std::string>& names, const std::string& legs_under = "root") {
  Rows rows;
  auto add = [&](const std::string& role, const std::string& parent_role) {
    auto it = names.find(role);
    if (it == names.end()) return;
    std::string parent;
    for (std::string p = parent_role; !p.empty();) {
      if (names.count(p)) {
        parent = names.at(p);
        break;
      }
      // a role this rig lacks: hang from the one above it
      static const std::map<std::string, std::string> kUp = {
          {"lowspine", "root"}, {"spine", "lowspine"}, {"chest", "spine"},  {"neck", "chest"},
          {"neck2", "neck"},    {"head", "neck2"},     {"hipjoint", "root"}};
      auto up = kUp.find(p.rfind("l_", 0) == 0 || p.rfind("r_", 0) == 0 ? p.substr(2) : p);
      p = up == kUp.end() ? "" : up->second;
    }
    rows.emplace_back(it->second, parent, role);
  };
  add("root", "");
  for (const char* r : {"lowspine", "spine", "chest", "neck", "neck2", "head", "headtop"}) {
    static const std::map<std::string, std::string> kParent = {
        {"lowspine", "root"}, {"spine", "lowspine"}, {"chest", "spine"}, {"neck", "chest"},
        {"neck2", "neck"},    {"head", "neck2"},     {"headtop", "head"}};
    add(r, kParent.at(r));
  }
  for (const char* side : {"l_", "r_"}) {
    const std::string s = side;
    const std::string arm_parent =
        names.count(s + "clavicle_parent") ? names.at(s + "clavicle_parent") : "chest";
    add(s + "clavicle", arm_parent);
    add(s + "upperarm", names.count(s + "clavicle") ? s + "clavicle" : arm_parent);
    add(s + "forearm", s + "upperarm");
    add(s + "wrist", s + "forearm");
    add(s + "hand", names.count(s + "wrist") ? s + "wrist" : s + "forearm");
    add(s + "hipjoint", legs_under);
    add(s + "thigh", names.count(s + "hipjoint") ? s + "hipjoint" : legs_under);
    add(s + "calf", s + "thigh");
    add(s + "foot", s + "calf");
    add(s + "toe", s + "foot");
    add(s + "toeend", s + "toe");
  }
  return rows;
}

// Names per role from a pattern: "{S}" becomes the side word.
std::map<std::string, std::string> Names(const std::map<std::string, std::string>& center,
                                         const std::map<std::string, std::string>& sided,
                                         const std::string& left, const std::string& right) {
  std::map<std::string, std::string> names = center;
  for (const auto& [role, pattern] : sided) {
    for (const auto& [prefix, word] : {std::pair{"l_", left}, std::pair{"r_", right}}) {
      std::string n = pattern;
      size_t at = n.find("{S}");
      if (at != std::string::npos) n.replace(at, 3, word);
      names[std::string(prefix) + role] = n;
    }
  }
  return names;
}

std::map<std::string, std::string> Expect(const std::map<std::string, std::string>& names,
                                          const std::map<std::string, std::string>& parts) {
  std::map<std::string, std::string> expected;
  for (const auto& [part, role] : parts) expected[part] = names.at(role);
  return expected;
}

// The usual part -> role expectation for a full rig.
std::map<std::string, std::string> Usual(const std::string& chest = "chest",
                                         const std::string& wrist = "hand") {
  std::map<std::string, std::string> parts = {
      {"root", "root"}, {"chest", chest}, {"neck", "neck"}, {"head", "head"}};
  for (const auto& [side, role] : {std::pair{"left_", "l_"}, std::pair{"right_", "r_"}}) {
    const std::string s = side, r = role;
    parts[s + "hip"] = r + "thigh";
    parts[s + "knee"] = r + "calf";
    parts[s + "ankle"] = r + "foot";
    parts[s + "toe"] = r + "toe";
    parts[s + "shoulder"] = r + "upperarm";
    parts[s + "elbow"] = r + "forearm";
    parts[s + "wrist"] = r + wrist;
  }
  return parts;
}

void ExpectMapping(const SkeletonAnimation& skeleton,
                   const std::map<std::string, std::string>& expected, const std::string& scheme) {
  AutoMapping m = MapAutomatically(skeleton);
  EXPECT_EQ(m.scheme, scheme);
  for (const auto& [part, name] : expected) {
    auto it = m.mapping.joints.find(part);
    ASSERT_NE(it, m.mapping.joints.end()) << part << " not mapped";
    EXPECT_EQ(it->second, name) << part;
  }
}

TEST(NameWordsTest, SplitsTheNamingsUsersMeet) {
  using W = std::vector<std::string>;
  EXPECT_EQ(NameWords("mixamorig:LeftUpLeg"), (W{"left", "up", "leg"}));
  EXPECT_EQ(NameWords("Bip01 L Thigh"), (W{"bip01", "l", "thigh"}));
  EXPECT_EQ(NameWords("thigh.L"), (W{"thigh", "l"}));
  EXPECT_EQ(NameWords("DEF-upper_arm.R"), (W{"def", "upper", "arm", "r"}));
  EXPECT_EQ(NameWords("LHipJoint"), (W{"l", "hip", "joint"}));
  EXPECT_EQ(NameWords("spine_01"), (W{"spine", "01"}));
  EXPECT_EQ(NameWords("Armature|Hips"), (W{"hips"}));
}

TEST(AutoMappingTest, Mixamo) {
  auto names = Names({{"root", "mixamorig:Hips"},
                      {"lowspine", "mixamorig:Spine"},
                      {"spine", "mixamorig:Spine1"},
                      {"chest", "mixamorig:Spine2"},
                      {"neck", "mixamorig:Neck"},
                      {"head", "mixamorig:Head"},
                      {"headtop", "mixamorig:HeadTop_End"}},
                     {{"clavicle", "mixamorig:{S}Shoulder"},
                      {"upperarm", "mixamorig:{S}Arm"},
                      {"forearm", "mixamorig:{S}ForeArm"},
                      {"hand", "mixamorig:{S}Hand"},
                      {"thigh", "mixamorig:{S}UpLeg"},
                      {"calf", "mixamorig:{S}Leg"},
                      {"foot", "mixamorig:{S}Foot"},
                      {"toe", "mixamorig:{S}ToeBase"},
                      {"toeend", "mixamorig:{S}Toe_End"}},
                     "Left", "Right");
  ExpectMapping(Skeleton(Rig(names)), Expect(names, Usual()), "Mixamo");
  // Without the namespace, as some exports write it.
  for (auto& [role, n] : names) n = n.substr(n.find(':') + 1);
  ExpectMapping(Skeleton(Rig(names)), Expect(names, Usual()), "Mixamo (no namespace)");
}

TEST(AutoMappingTest, CmuBothNamings) {
  // The cgspeed conversion: LHipJoint, LowerBack, clavicles called LeftShoulder.
  auto cgspeed = Names({{"root", "Hips"},
                        {"lowspine", "LowerBack"},
                        {"spine", "Spine"},
                        {"chest", "Spine1"},
                        {"neck", "Neck"},
                        {"neck2", "Neck1"},
                        {"head", "Head"}},
                       {{"hipjoint", "{S}HipJoint"},
                        {"thigh", "{S}UpLeg"},
                        {"calf", "{S}Leg"},
                        {"foot", "{S}Foot"},
                        {"toe", "{S}ToeBase"},
                        {"clavicle", "{S}Shoulder"},
                        {"upperarm", "{S}Arm"},
                        {"forearm", "{S}ForeArm"},
                        {"hand", "{S}Hand"}},
                       "Left", "Right");
  cgspeed["l_hipjoint"] = "LHipJoint";
  cgspeed["r_hipjoint"] = "RHipJoint";
  ExpectMapping(Skeleton(Rig(cgspeed)), Expect(cgspeed, Usual("chest")),
                "CMU (Hips, LeftUpLeg, LeftArm...)");
  // The other common naming: LeftHip/LeftKnee/LeftAnkle, collars, LeftShoulder the upper arm.
  auto second = Names(
      {{"root", "Hips"}, {"spine", "Ab"}, {"chest", "Chest"}, {"neck", "Neck"}, {"head", "Head"}},
      {{"thigh", "{S}Hip"},
       {"calf", "{S}Knee"},
       {"foot", "{S}Ankle"},
       {"toe", "{S}Toes"},
       {"clavicle", "{S}Collar"},
       {"upperarm", "{S}Shoulder"},
       {"forearm", "{S}Elbow"},
       {"wrist", "{S}Wrist"}},
      "Left", "Right");
  ExpectMapping(Skeleton(Rig(second)), Expect(second, Usual("chest", "wrist")),
                "CMU (Hips, LeftHip, LeftShoulder...)");
  // The ASF/AMC names, one word each: lfemur, lhumerus, lwrist before lhand.
  auto asf = Names({{"root", "root"},
                    {"lowspine", "lowerback"},
                    {"spine", "upperback"},
                    {"chest", "thorax"},
                    {"neck", "lowerneck"},
                    {"neck2", "upperneck"},
                    {"head", "head"}},
                   {{"hipjoint", "{S}hipjoint"},
                    {"thigh", "{S}femur"},
                    {"calf", "{S}tibia"},
                    {"foot", "{S}foot"},
                    {"toe", "{S}toes"},
                    {"clavicle", "{S}clavicle"},
                    {"upperarm", "{S}humerus"},
                    {"forearm", "{S}radius"},
                    {"wrist", "{S}wrist"},
                    {"hand", "{S}hand"}},
                   "l", "r");
  ExpectMapping(Skeleton(Rig(asf)), Expect(asf, Usual("chest", "wrist")),
                "CMU ASF (lfemur, lhumerus...)");
}

TEST(AutoMappingTest, UnrealUnityLafan) {
  auto unreal = Names({{"root", "pelvis"},
                       {"lowspine", "spine_01"},
                       {"spine", "spine_02"},
                       {"chest", "spine_03"},
                       {"neck", "neck_01"},
                       {"head", "head"}},
                      {{"clavicle", "clavicle_{S}"},
                       {"upperarm", "upperarm_{S}"},
                       {"forearm", "lowerarm_{S}"},
                       {"hand", "hand_{S}"},
                       {"thigh", "thigh_{S}"},
                       {"calf", "calf_{S}"},
                       {"foot", "foot_{S}"},
                       {"toe", "ball_{S}"}},
                      "l", "r");
  Rows rows = Rig(unreal);
  // Unreal's skeletons start at a "root" on the floor, above the pelvis.
  rows.insert(rows.begin(), {"root", "", "root"});
  std::get<1>(rows[1]) = "root";
  ExpectMapping(Skeleton(rows), Expect(unreal, Usual()), "Unreal");

  auto unity = Names({{"root", "Hips"},
                      {"spine", "Spine"},
                      {"chest", "Chest"},
                      {"neck", "Neck"},
                      {"head", "Head"}},
                     {{"clavicle", "{S}Shoulder"},
                      {"upperarm", "{S}UpperArm"},
                      {"forearm", "{S}LowerArm"},
                      {"hand", "{S}Hand"},
                      {"thigh", "{S}UpperLeg"},
                      {"calf", "{S}LowerLeg"},
                      {"foot", "{S}Foot"},
                      {"toe", "{S}Toes"}},
                     "Left", "Right");
  ExpectMapping(Skeleton(Rig(unity)), Expect(unity, Usual()), "Unity humanoid");

  auto lafan = Names({{"root", "Hips"},
                      {"lowspine", "Spine"},
                      {"spine", "Spine1"},
                      {"chest", "Spine2"},
                      {"neck", "Neck"},
                      {"head", "Head"}},
                     {{"clavicle", "{S}Shoulder"},
                      {"upperarm", "{S}Arm"},
                      {"forearm", "{S}ForeArm"},
                      {"hand", "{S}Hand"},
                      {"thigh", "{S}UpLeg"},
                      {"calf", "{S}Leg"},
                      {"foot", "{S}Foot"},
                      {"toe", "{S}Toe"}},
                     "Left", "Right");
  ExpectMapping(Skeleton(Rig(lafan)), Expect(lafan, Usual()), "LAFAN1");
}

TEST(AutoMappingTest, RigifyAndBiped) {
  // Blender's metarig: the hips are "spine", the head "spine.006", nothing says neck or head.
  auto rigify = Names({{"root", "spine"},
                       {"lowspine", "spine.001"},
                       {"spine", "spine.002"},
                       {"chest", "spine.003"},
                       {"neck", "spine.004"},
                       {"neck2", "spine.005"},
                       {"head", "spine.006"}},
                      {{"clavicle", "shoulder.{S}"},
                       {"upperarm", "upper_arm.{S}"},
                       {"forearm", "forearm.{S}"},
                       {"hand", "hand.{S}"},
                       {"thigh", "thigh.{S}"},
                       {"calf", "shin.{S}"},
                       {"foot", "foot.{S}"},
                       {"toe", "toe.{S}"}},
                      "L", "R");
  ExpectMapping(Skeleton(Rig(rigify)), Expect(rigify, Usual()), "Blender Rigify/metarig");
  // Rigify's deform bones.
  for (auto& [role, n] : rigify) n = "DEF-" + n;
  AutoMapping def = MapAutomatically(Skeleton(Rig(rigify)));
  EXPECT_EQ(def.mapping.joints.at("left_knee"), "DEF-shin.L");
  EXPECT_EQ(def.mapping.joints.at("head"), "DEF-spine.006");

  // 3ds Max Biped: clavicles hang from the neck, thighs from the spine, Bip01 above the pelvis.
  auto biped = Names({{"root", "Bip01 Pelvis"},
                      {"lowspine", "Bip01 Spine"},
                      {"spine", "Bip01 Spine1"},
                      {"chest", "Bip01 Spine2"},
                      {"neck", "Bip01 Neck"},
                      {"head", "Bip01 Head"}},
                     {{"clavicle", "Bip01 {S} Clavicle"},
                      {"upperarm", "Bip01 {S} UpperArm"},
                      {"forearm", "Bip01 {S} Forearm"},
                      {"hand", "Bip01 {S} Hand"},
                      {"thigh", "Bip01 {S} Thigh"},
                      {"calf", "Bip01 {S} Calf"},
                      {"foot", "Bip01 {S} Foot"},
                      {"toe", "Bip01 {S} Toe0"}},
                     "L", "R");
  biped["l_clavicle_parent"] = "neck";
  biped["r_clavicle_parent"] = "neck";
  Rows rows = Rig(biped, "lowspine");
  rows.insert(rows.begin(), {"Bip01", "", "root"});
  std::get<1>(rows[1]) = "Bip01";
  ExpectMapping(Skeleton(rows), Expect(biped, Usual()), "3ds Max Biped");
}

TEST(AutoMappingTest, SidesFromTheRestPoseWhenNamesDoNotSay) {
  // Blender's duplicates: "thigh" and "thigh.001"; which is left only the geometry says.
  std::map<std::string, std::string> names = {
      {"root", "hips"}, {"spine", "spine"}, {"chest", "chest"}, {"neck", "neck"}, {"head", "head"}};
  for (const char* role : {"upperarm", "forearm", "hand", "thigh", "calf", "foot", "toe"}) {
    const std::map<std::string, std::string> word = {
        {"upperarm", "upper_arm"}, {"forearm", "forearm"}, {"hand", "hand"}, {"thigh", "thigh"},
        {"calf", "shin"},          {"foot", "foot"},       {"toe", "toe"}};
    names[std::string("l_") + role] = word.at(role);
    names[std::string("r_") + role] = word.at(role) + ".001";
  }
  AutoMapping m = MapAutomatically(Skeleton(Rig(names)));
  EXPECT_EQ(m.mapping.joints.at("left_hip"), "thigh");
  EXPECT_EQ(m.mapping.joints.at("right_knee"), "shin.001");
  EXPECT_EQ(m.mapping.joints.at("left_shoulder"), "upper_arm");
  EXPECT_EQ(m.mapping.joints.at("right_wrist"), "hand.001");
  EXPECT_NE(m.scheme.find("sides from the rest pose"), std::string::npos);
  // The same names on a skeleton whose "thigh" is on the right.
  AutoMapping mirrored = MapAutomatically(Skeleton(Rig(names), /*mirror_geometry=*/true));
  EXPECT_EQ(mirrored.mapping.joints.at("left_hip"), "thigh.001");
  EXPECT_EQ(mirrored.mapping.joints.at("left_shoulder"), "upper_arm.001");
}

TEST(AutoMappingTest, FailureNamesTheMissingPartsAndTheNearestJoints) {
  auto names = Names({{"root", "Hips"}, {"chest", "Chest"}, {"head", "Head"}},
                     {{"upperarm", "{S}Arm"},
                      {"forearm", "{S}ForeArm"},
                      {"thigh", "{S}UpLeg"},
                      {"calf", "{S}Lg"},
                      {"foot", "{S}Foot"}},
                     "Left", "Right");
  try {
    MapAutomatically(Skeleton(Rig(names)));
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test.fbx: --map auto cannot find"), std::string::npos) << what;
    EXPECT_NE(what.find("left_knee"), std::string::npos) << what;
    EXPECT_NE(what.find("LeftLg"), std::string::npos) << what;  // the nearest name
    EXPECT_NE(what.find("--map FILE"), std::string::npos) << what;
  }
}

TEST(AutoMappingTest, ResolveMappingReadsPresetsAndAuto) {
  auto names = Names({{"root", "root"}, {"chest", "chest"}, {"neck", "neck"}, {"head", "head"}},
                     {{"upperarm", "{S}_shoulder"},
                      {"forearm", "{S}_elbow"},
                      {"wrist", "{S}_wrist"},
                      {"thigh", "{S}_hip"},
                      {"calf", "{S}_knee"},
                      {"foot", "{S}_ankle"},
                      {"toe", "{S}_toe"}},
                     "left", "right");
  SkeletonAnimation s = Skeleton(Rig(names));
  std::vector<std::string> notes;
  JointMapping automatic = ResolveMapping("auto", s, &notes);
  JointMapping preset = ResolveMapping("ragdoll", s);
  EXPECT_EQ(automatic.joints, preset.joints);
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes[0].find("mapping auto: ragdoll: root=root chest=chest"), std::string::npos)
      << notes[0];
}

}  // namespace
}  // namespace ragdoll::motion
