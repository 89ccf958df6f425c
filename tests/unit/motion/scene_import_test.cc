// The scene reader on files written by Assimp's own exporters (FBX binary and ASCII, glTF 2,
// GLB, COLLADA) from the project's clips on Mixamo- and CMU-named skeletons, and on damaged
// copies of them.
#include "motion/scene_import.h"
#include "character/skeleton.h"

#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <assimp/Exporter.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "character/motion_io.h"
#include "common/config_section.h"
#include "motion/auto_mapping.h"
#include "motion/retarget.h"

namespace ragdoll::motion {

using character::AngleBetween;
using character::Character;
using character::FindJoint;
using character::Humanoid3dJoints;
using character::LoadMotion;
using character::MotionClip;
using character::Pose;
using character::Quat;
using character::Vec3;

namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

// An Assimp scene holding `bvh`'s skeleton under an "Armature" node, with one animation per
// entry of `names` (all the same motion), keys at the frames, `ticks_per_second` as given.
// With `nodes` kPosed*, the nodes hold the first frame's pose (as Blender writes them); with
// kPosedSkinned a skinned triangle carries the rest pose as its bones' offset matrices.
enum class Nodes { kRest, kPosedBare, kPosedSkinned };
aiScene* SceneFromBvh(const BvhMotion& bvh, const std::vector<std::string>& names,
                      Nodes pose = Nodes::kRest) {
  auto* scene = new aiScene();
  scene->mRootNode = new aiNode("Scene");
  auto* armature = new aiNode("Armature");
  armature->mParent = scene->mRootNode;
  scene->mRootNode->mNumChildren = 1;
  scene->mRootNode->mChildren = new aiNode* [1] { armature };
  std::vector<aiNode*> nodes;
  std::vector<std::vector<aiNode*>> children(bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    const BvhJoint& joint = bvh.joints[j];
    auto* node = new aiNode(joint.name);
    node->mTransformation = aiMatrix4x4();
    node->mTransformation.a4 = static_cast<ai_real>(joint.offset[0]);
    node->mTransformation.b4 = static_cast<ai_real>(joint.offset[1]);
    node->mTransformation.c4 = static_cast<ai_real>(joint.offset[2]);
    if (pose != Nodes::kRest && !joint.end_site) {
      const Quat q = bvh.LocalRotation(0, static_cast<int>(j));
      const Vec3 t = bvh.LocalTranslation(0, static_cast<int>(j));
      node->mTransformation =
          aiMatrix4x4(aiVector3D(1, 1, 1),
                      aiQuaternion(static_cast<ai_real>(q[0]), static_cast<ai_real>(q[1]),
                                   static_cast<ai_real>(q[2]), static_cast<ai_real>(q[3])),
                      aiVector3D(static_cast<ai_real>(t[0]), static_cast<ai_real>(t[1]),
                                 static_cast<ai_real>(t[2])));
    }
    nodes.push_back(node);
    if (joint.parent >= 0) children[joint.parent].push_back(node);
  }
  auto attach = [](aiNode* parent, const std::vector<aiNode*>& kids) {
    if (kids.empty()) return;
    parent->mNumChildren = static_cast<unsigned>(kids.size());
    parent->mChildren = new aiNode*[kids.size()];
    for (size_t k = 0; k < kids.size(); ++k) {
      parent->mChildren[k] = kids[k];
      kids[k]->mParent = parent;
    }
  };
  attach(armature, {nodes[0]});
  for (size_t j = 0; j < nodes.size(); ++j) attach(nodes[j], children[j]);

  scene->mNumAnimations = static_cast<unsigned>(names.size());
  scene->mAnimations = new aiAnimation*[names.size()];
  for (size_t a = 0; a < names.size(); ++a) {
    auto* anim = new aiAnimation();
    anim->mName = names[a];
    // Times in seconds (one tick per second): Assimp's COLLADA exporter writes key times as
    // seconds whatever the tick rate, its glTF exporter converts them.
    anim->mTicksPerSecond = 1;
    anim->mDuration = (bvh.num_frames() - 1) * bvh.frame_time;
    std::vector<aiNodeAnim*> channels;
    for (size_t j = 0; j < bvh.joints.size(); ++j) {
      if (bvh.joints[j].end_site) continue;
      auto* ch = new aiNodeAnim();
      ch->mNodeName = bvh.joints[j].name;
      const unsigned n = static_cast<unsigned>(bvh.num_frames());
      ch->mNumPositionKeys = ch->mNumRotationKeys = ch->mNumScalingKeys = n;
      ch->mPositionKeys = new aiVectorKey[n];
      ch->mRotationKeys = new aiQuatKey[n];
      ch->mScalingKeys = new aiVectorKey[n];
      for (unsigned f = 0; f < n; ++f) {
        const Vec3 t = bvh.LocalTranslation(static_cast<int>(f), static_cast<int>(j));
        const Quat q = bvh.LocalRotation(static_cast<int>(f), static_cast<int>(j));
        const double time = f * bvh.frame_time;
        ch->mPositionKeys[f] =
            aiVectorKey(time, aiVector3D(static_cast<ai_real>(t[0]), static_cast<ai_real>(t[1]),
                                         static_cast<ai_real>(t[2])));
        ch->mRotationKeys[f] =
            aiQuatKey(time, aiQuaternion(static_cast<ai_real>(q[0]), static_cast<ai_real>(q[1]),
                                         static_cast<ai_real>(q[2]), static_cast<ai_real>(q[3])));
        ch->mScalingKeys[f] = aiVectorKey(time, aiVector3D(1, 1, 1));
      }
      channels.push_back(ch);
    }
    anim->mNumChannels = static_cast<unsigned>(channels.size());
    anim->mChannels = new aiNodeAnim*[channels.size()];
    std::copy(channels.begin(), channels.end(), anim->mChannels);
    scene->mAnimations[a] = anim;
  }
  // Exporters want a material; a scene without meshes is "incomplete" to Assimp.
  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial* [1] { new aiMaterial() };
  if (pose != Nodes::kPosedSkinned) {
    scene->mFlags |= AI_SCENE_FLAGS_INCOMPLETE;
    return scene;
  }
  // A triangle skinned to every joint; each bone's offset matrix is the inverse of the joint's
  // rest (all rotations zero) world transform, the mesh node at the scene root.
  auto* mesh = new aiMesh();
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  mesh->mNumVertices = 3;
  mesh->mVertices = new aiVector3D[3];
  mesh->mVertices[1] = aiVector3D(1, 0, 0);
  mesh->mVertices[2] = aiVector3D(0, 1, 0);
  mesh->mNumFaces = 1;
  mesh->mFaces = new aiFace[1];
  mesh->mFaces[0].mNumIndices = 3;
  mesh->mFaces[0].mIndices = new unsigned[3];
  for (unsigned i = 0; i < 3; ++i) mesh->mFaces[0].mIndices[i] = i;
  std::vector<aiBone*> bones;
  std::vector<Vec3> rest(bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    const BvhJoint& joint = bvh.joints[j];
    rest[j] = joint.offset;
    if (joint.parent >= 0) {
      for (int i = 0; i < 3; ++i) rest[j][i] += rest[joint.parent][i];
    }
    if (joint.end_site) continue;
    auto* bone = new aiBone();
    bone->mName = joint.name;
    aiMatrix4x4 offset;
    offset.a4 = static_cast<ai_real>(-rest[j][0]);
    offset.b4 = static_cast<ai_real>(-rest[j][1]);
    offset.c4 = static_cast<ai_real>(-rest[j][2]);
    bone->mOffsetMatrix = offset;
    bone->mNumWeights = 1;
    bone->mWeights = new aiVertexWeight[1];
    bone->mWeights[0] = aiVertexWeight(static_cast<unsigned>(j % 3), 0.1f);
    bones.push_back(bone);
  }
  mesh->mNumBones = static_cast<unsigned>(bones.size());
  mesh->mBones = new aiBone*[bones.size()];
  std::copy(bones.begin(), bones.end(), mesh->mBones);
  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh*[1];
  scene->mMeshes[0] = mesh;
  auto* holder = new aiNode("Body");
  holder->mParent = scene->mRootNode;
  holder->mNumMeshes = 1;
  holder->mMeshes = new unsigned[1];
  holder->mMeshes[0] = 0;
  auto** root_children = new aiNode*[2];
  root_children[0] = scene->mRootNode->mChildren[0];
  root_children[1] = holder;
  delete[] scene->mRootNode->mChildren;
  scene->mRootNode->mChildren = root_children;
  scene->mRootNode->mNumChildren = 2;
  return scene;
}

struct Format {
  const char* id;         // Assimp's exporter
  const char* extension;  // of the file written
};
// Assimp 5.2's FBX exporter is not among them: its binary files are refused by its own importer
// ("block offset is out of range") and its ASCII files keep only each track's first and last
// key. FBX is tested with files Blender writes (tests/integration/motion_import_test.sh).
const Format kFormats[] = {{"gltf2", ".gltf"}, {"glb2", ".glb"}, {"collada", ".dae"}};

class SceneImportTest : public ::testing::Test {
 protected:
  SceneImportTest()
      : character_(Character::Load(kAssets + "/character/humanoid.xml")),
        walk_(LoadMotion(kAssets + "/motions/walk.json")),
        dir_(::testing::TempDir() + "/scene_import_test") {
    std::filesystem::create_directories(dir_);
  }

  // `clip` exported on the `naming` skeleton (Y up, centimetres, as tools write), written by
  // Assimp's `format` exporter; the path, or "" with the exporter's complaint in `why`.
  std::string Write(const MotionClip& clip, const std::string& naming, const Format& format,
                    const std::vector<std::string>& animations, std::string* why,
                    Nodes nodes = Nodes::kRest) {
    ExportOptions options;
    options.y_up = true;
    options.units_per_metre = 100;
    BvhMotion bvh = ClipToBvh(clip, *character_, ReadJointMapping(naming), options);
    std::unique_ptr<aiScene> scene(SceneFromBvh(bvh, animations, nodes));
    const char* suffix[] = {"", "_posed", "_skinned"};
    const std::string path = dir_ + "/" + clip.name() + "_" + naming + "_" + format.id +
                             suffix[static_cast<int>(nodes)] + format.extension;
    Assimp::Exporter exporter;
    if (exporter.Export(scene.get(), format.id, path) != aiReturn_SUCCESS) {
      *why = exporter.GetErrorString();
      return "";
    }
    return path;
  }

  // Largest joint rotation difference (radians) and root position difference (metres).
  static void Compare(const MotionClip& a, const MotionClip& b, double* rotation,
                      double* position) {
    *rotation = *position = 0;
    ASSERT_EQ(a.num_frames(), b.num_frames());
    for (int f = 0; f < a.num_frames(); ++f) {
      const Pose &pa = a.frame(f), &pb = b.frame(f);
      *rotation = std::max(*rotation, AngleBetween(pa.root_rotation, pb.root_rotation));
      for (size_t j = 0; j < pa.joint_rotations.size(); ++j) {
        *rotation = std::max(*rotation, AngleBetween(pa.joint_rotations[j], pb.joint_rotations[j]));
      }
      for (int i = 0; i < 3; ++i) {
        *position = std::max(*position, std::abs(pa.root_position[i] - pb.root_position[i]));
      }
    }
  }

  std::shared_ptr<const Character> character_;
  MotionClip walk_;
  std::string dir_;
};

TEST_F(SceneImportTest, EveryFormatRoundTripsOnMixamoAndCmuSkeletons) {
  ImportOptions options;
  options.feet = ImportOptions::Feet::kRest;  // compare rotations exactly
  for (const char* naming : {"mixamo", "cmu"}) {
    for (const Format& format : kFormats) {
      // Assimp's COLLADA exporter turns "mixamorig:Hips" into ids its importer cannot resolve;
      // Blender's COLLADA files with Mixamo names are tested in the integration test.
      if (std::string(naming) == "mixamo" && std::string(format.id) == "collada") continue;
      std::string why;
      const std::string path = Write(walk_, naming, format, {"Take 001"}, &why);
      ASSERT_FALSE(path.empty()) << format.id << ": " << why;
      std::vector<std::string> notes;
      SkeletonAnimation source;
      try {
        source = LoadSkeletonAnimation(path, "", &notes);
      } catch (const ConfigError& e) {
        ADD_FAILURE() << naming << " " << format.id << ": " << e.what();
        continue;
      }
      EXPECT_EQ(source.num_frames(), walk_.num_frames()) << naming << " " << format.id;
      EXPECT_NEAR(source.frame_time, walk_.frame_duration(0), 1e-6) << naming << " " << format.id;
      AutoMapping automatic = MapAutomatically(source);
      EXPECT_EQ(automatic.mapping.joints.at("left_knee"),
                ReadJointMapping(naming).joints.at("left_knee"))
          << naming << " " << format.id;
      MotionClip back = Retarget(source, automatic.mapping, *character_, options);
      if (back.num_frames() != walk_.num_frames()) continue;
      double rotation, position;
      Compare(walk_, back, &rotation, &position);
      std::printf("%-7s %-8s %7zu bytes  rotation error %.2e rad  root error %.2e m\n", naming,
                  format.id, static_cast<size_t>(std::filesystem::file_size(path)), rotation,
                  position);
      EXPECT_LT(rotation, 1e-4) << naming << " " << format.id;  // float precision in the files
      EXPECT_LT(position, 1e-4) << naming << " " << format.id;
    }
  }
}

// Node transforms holding the first frame's pose (as Blender writes them) and the rest pose in a
// skinned mesh's bind matrices: the bind pose is the rest pose, and the clip comes back whole.
TEST_F(SceneImportTest, TheSkinnedMeshsBindPoseIsTheRestPose) {
  ImportOptions options;
  options.feet = ImportOptions::Feet::kRest;
  for (const Format& format : {kFormats[0], kFormats[1]}) {
    std::string why;
    const std::string path = Write(walk_, "cmu", format, {"Take 001"}, &why, Nodes::kPosedSkinned);
    ASSERT_FALSE(path.empty()) << why;
    std::vector<std::string> notes;
    SkeletonAnimation source = LoadSkeletonAnimation(path, "", &notes);
    bool noted = false;
    for (const std::string& n : notes) noted |= n.rfind("rest pose: the skinned mesh's", 0) == 0;
    EXPECT_TRUE(noted) << format.id;
    MotionClip back = Retarget(source, ReadJointMapping("cmu"), *character_, options);
    double rotation, position;
    Compare(walk_, back, &rotation, &position);
    std::printf("skinned %-6s rotation error %.2e rad  root error %.2e m\n", format.id, rotation,
                position);
    EXPECT_LT(rotation, 1e-4) << format.id;
    EXPECT_LT(position, 1e-4) << format.id;
  }
}

// The same posed nodes without a skinned mesh (Blender's export of a bare armature): no bind
// pose says what the rest is, yet knees and elbows take their hinge axis from the motion and
// come back as they were.
TEST_F(SceneImportTest, KneesAndElbowsOfAPosedBareArmatureBendAsTheyShould) {
  ImportOptions options;
  options.feet = ImportOptions::Feet::kRest;
  std::string why;
  const std::string path = Write(walk_, "cmu", kFormats[0], {"Take 001"}, &why, Nodes::kPosedBare);
  ASSERT_FALSE(path.empty()) << why;
  MotionClip back =
      Retarget(LoadSkeletonAnimation(path), ReadJointMapping("cmu"), *character_, options);
  ASSERT_EQ(back.num_frames(), walk_.num_frames());
  double hinge = 0, other = 0;
  for (int f = 0; f < walk_.num_frames(); ++f) {
    for (const auto& joint : Humanoid3dJoints()) {
      const int j = FindJoint(joint.name);
      const double e =
          AngleBetween(walk_.frame(f).joint_rotations[j], back.frame(f).joint_rotations[j]);
      const bool is_hinge = joint.name.find("knee") != std::string::npos ||
                            joint.name.find("elbow") != std::string::npos;
      (is_hinge ? hinge : other) = std::max(is_hinge ? hinge : other, e);
    }
  }
  std::printf("posed bare armature: knees and elbows %.2e rad, other joints %.2e rad\n", hinge,
              other);
  EXPECT_LT(hinge, 0.0175);  // 1 degree
}

TEST_F(SceneImportTest, ListsAnimationsAndTakesOneByNameOrIndex) {
  std::string why;
  const std::string path = Write(walk_, "mixamo", kFormats[0], {"Idle", "Walk"}, &why);
  ASSERT_FALSE(path.empty()) << why;
  std::vector<AnimationInfo> list = ListAnimations(path);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].name, "Idle");
  EXPECT_EQ(list[1].name, "Walk");
  EXPECT_NEAR(list[1].duration, walk_.duration(), 1e-3);
  std::vector<std::string> notes;
  SkeletonAnimation first = LoadSkeletonAnimation(path, "", &notes);
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes[0].find("2 animations: 0 'Idle'"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("--animation"), std::string::npos) << notes[0];
  EXPECT_EQ(LoadSkeletonAnimation(path, "Walk").num_frames(), walk_.num_frames());
  EXPECT_EQ(LoadSkeletonAnimation(path, "1").num_frames(), walk_.num_frames());
  try {
    LoadSkeletonAnimation(path, "Run");
    FAIL() << "took an animation the file does not have";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no animation 'Run'; the file has 0 'Idle'"),
              std::string::npos)
        << e.what();
  }
}

// Truncated and damaged copies of each format: a ConfigError naming the file, never a crash.
TEST_F(SceneImportTest, MalformedAndTruncatedFilesAreRefused) {
  for (const Format& format : kFormats) {
    std::string why;
    const std::string path = Write(walk_, "cmu", format, {"Take 001"}, &why);
    ASSERT_FALSE(path.empty()) << why;
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    struct Variant {
      std::string name, bytes;
    };
    std::string garbled = bytes;
    for (size_t i = garbled.size() / 3; i < garbled.size() / 3 + 64 && i < garbled.size(); ++i) {
      garbled[i] = static_cast<char>(garbled[i] ^ 0x5a);
    }
    const Variant variants[] = {{"half", bytes.substr(0, bytes.size() / 2)},
                                {"header", bytes.substr(0, 40)},
                                {"empty", ""},
                                {"garbled", garbled}};
    for (const Variant& v : variants) {
      const std::string damaged = dir_ + "/" + v.name + "_" + format.id + format.extension;
      std::ofstream(damaged, std::ios::binary) << v.bytes;
      try {
        SkeletonAnimation s = LoadSkeletonAnimation(damaged);
        // A garbled byte range inside key values can leave a readable file: it must still be a
        // whole animation.
        EXPECT_EQ(v.name, "garbled") << format.id << " " << v.name << " was read";
        EXPECT_GE(s.num_frames(), 2);
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(damaged), std::string::npos) << e.what();
      }
    }
  }
}

TEST_F(SceneImportTest, FilesWithoutAnimationOrReaderAreRefusedClearly) {
  EXPECT_THROW(LoadSkeletonAnimation(dir_ + "/missing.fbx"), ConfigError);
  const std::string text = dir_ + "/notes.txt";
  std::ofstream(text) << "not a scene\n";
  try {
    LoadSkeletonAnimation(text);
    FAIL() << "read a text file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(text + ": cannot read it"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ragdoll::motion
