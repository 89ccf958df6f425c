#include "motion/scene_import.h"

#include <assimp/config.h>
#include <assimp/scene.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "common/config_section.h"

namespace ragdoll::motion {

using character::Normalized;
using character::Quat;
using character::Slerp;
using character::Vec3;

namespace {

// A 4x4 transform in double precision (column vectors: p' = M p).
struct Mat4 {
  double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
};

Mat4 Mul(const Mat4& a, const Mat4& b) {
  Mat4 r;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a.m[i][k] * b.m[k][j];
      r.m[i][j] = s;
    }
  }
  return r;
}

Mat4 FromAssimp(const aiMatrix4x4& a) {
  Mat4 r;
  for (unsigned i = 0; i < 4; ++i) {
    for (unsigned j = 0; j < 4; ++j) r.m[i][j] = a[i][j];
  }
  return r;
}

// Translation, rotation (w, x, y, z) and scale composed as T R S.
Mat4 Compose(const Vec3& t, const Quat& q, const Vec3& s) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  Mat4 m;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.m[i][j] = r[i][j] * s[j];
    m.m[i][3] = t[i];
  }
  return m;
}

// The rotation and position of a transform; scale (and any shear) is taken out by
// Gram-Schmidt on the columns.
JointPose PoseOf(const Mat4& m) {
  Vec3 c[3];
  for (int j = 0; j < 3; ++j) c[j] = {m.m[0][j], m.m[1][j], m.m[2][j]};
  auto dot = [](const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto normalise = [&](Vec3& v) {
    double n = std::sqrt(dot(v, v));
    for (double& x : v) x /= n;
  };
  normalise(c[0]);
  double d = dot(c[1], c[0]);
  for (int i = 0; i < 3; ++i) c[1][i] -= d * c[0][i];
  normalise(c[1]);
  c[2] = {c[0][1] * c[1][2] - c[0][2] * c[1][1], c[0][2] * c[1][0] - c[0][0] * c[1][2],
          c[0][0] * c[1][1] - c[0][1] * c[1][0]};
  // MuJoCo's conversion, on the orthonormal matrix with columns c (row-major).
  const mjtNum rotation[9] = {c[0][0], c[1][0], c[2][0], c[0][1], c[1][1],
                              c[2][1], c[0][2], c[1][2], c[2][2]};
  Quat q;
  mju_mat2Quat(q.data(), rotation);
  return {Normalized(q), {m.m[0][3], m.m[1][3], m.m[2][3]}};
}

bool IsFinite(const Mat4& m) {
  for (const auto& row : m.m) {
    for (double x : row) {
      if (!std::isfinite(x)) return false;
    }
  }
  return true;
}

// A key track sampled at `time` (ticks): clamped outside the keys, interpolated between them.
template <typename Key, typename Value, typename Lerp>
Value Sample(const Key* keys, unsigned count, double time, Value fallback, Lerp lerp) {
  if (count == 0) return fallback;
  if (time <= keys[0].mTime) return lerp(keys[0].mValue, keys[0].mValue, 0.0);
  if (time >= keys[count - 1].mTime)
    return lerp(keys[count - 1].mValue, keys[count - 1].mValue, 0.0);
  const Key* next = std::upper_bound(keys, keys + count, time,
                                     [](double t, const Key& k) { return t < k.mTime; });
  const Key* prev = next - 1;
  const double span = next->mTime - prev->mTime;
  const double alpha = span > 0 ? (time - prev->mTime) / span : 0.0;
  return lerp(prev->mValue, next->mValue, alpha);
}

Vec3 LerpVec(const aiVector3D& a, const aiVector3D& b, double alpha) {
  return {a.x + (b.x - a.x) * alpha, a.y + (b.y - a.y) * alpha, a.z + (b.z - a.z) * alpha};
}

Quat SlerpQuat(const aiQuaternion& a, const aiQuaternion& b, double alpha) {
  const Quat qa = Normalized({a.w, a.x, a.y, a.z});
  if (alpha == 0) return qa;
  return Slerp(qa, Normalized({b.w, b.x, b.y, b.z}), alpha);
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool IsBvh(const std::string& path) {
  return Lower(std::filesystem::path(path).extension().string()) == ".bvh";
}

std::string Seconds(double s) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f s", s);
  return buffer;
}

double TicksPerSecond(const aiAnimation& a) {
  return a.mTicksPerSecond > 0 ? a.mTicksPerSecond : 25.0;  // Assimp's "unknown": 25
}

// Reads a scene with Assimp for its skeleton and animations only.
class Scene {
 public:
  explicit Scene(const std::string& path) : path_(path) {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw ConfigError(path + ": cannot open");
    importer_.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
    importer_.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);
    importer_.SetPropertyBool(AI_CONFIG_IMPORT_FBX_READ_MATERIALS, false);
    importer_.SetPropertyBool(AI_CONFIG_IMPORT_FBX_READ_TEXTURES, false);
    scene_ = importer_.ReadFile(path, 0);
    if (!scene_) {
      std::string why = importer_.GetErrorString();
      if (why.empty()) why = "not a format Assimp reads";
      throw ConfigError(path + ": cannot read it: " + why);
    }
    if (!scene_->mRootNode) throw ConfigError(path + ": the scene has no nodes");
  }

  std::vector<AnimationInfo> Animations() const {
    std::vector<AnimationInfo> list;
    for (unsigned i = 0; i < scene_->mNumAnimations; ++i) {
      const aiAnimation& a = *scene_->mAnimations[i];
      list.push_back(
          {a.mName.C_Str(), a.mDuration / TicksPerSecond(a), static_cast<int>(a.mNumChannels)});
    }
    return list;
  }

  SkeletonAnimation Load(const std::string& which, std::vector<std::string>* notes) const {
    auto note = [&](const std::string& n) {
      if (notes) notes->push_back(n);
    };
    const std::vector<AnimationInfo> list = Animations();
    if (list.empty()) {
      throw ConfigError(path_ + ": no animation in the file (" + Contents() + ")");
    }
    auto describe = [&]() {
      std::string s;
      for (size_t i = 0; i < list.size(); ++i) {
        s += (i ? ", " : "") + std::to_string(i) + " '" + list[i].name + "' (" +
             Seconds(list[i].duration) + ", " + std::to_string(list[i].channels) + " nodes)";
      }
      return s;
    };
    int index = -1;
    if (which.empty()) {
      for (size_t i = 0; i < list.size() && index < 0; ++i) {
        if (list[i].channels > 0) index = static_cast<int>(i);
      }
      if (index < 0) throw ConfigError(path_ + ": no animation moves anything: " + describe());
      if (list.size() > 1) {
        note(std::to_string(list.size()) + " animations: " + describe() + "; importing " +
             std::to_string(index) + " (choose with --animation NAME|INDEX)");
      }
    } else {
      for (size_t i = 0; i < list.size() && index < 0; ++i) {
        if (list[i].name == which) index = static_cast<int>(i);
      }
      if (index < 0 && !which.empty() &&
          std::all_of(which.begin(), which.end(), [](char c) { return std::isdigit(c); }) &&
          which.size() < 9 && std::stoul(which) < list.size()) {
        index = std::stoi(which);
      }
      if (index < 0) {
        throw ConfigError(path_ + ": no animation '" + which + "'; the file has " + describe());
      }
    }
    const std::string ignored = Contents();
    if (!ignored.empty()) note("ignored: " + ignored);
    return Sampled(*scene_->mAnimations[index], notes);
  }

 private:
  // What the file holds besides the skeleton: "2 meshes (skinned), 1 camera, 1 light".
  std::string Contents() const {
    std::string s;
    auto add = [&](unsigned n, const std::string& what) {
      if (n == 0) return;
      s += (s.empty() ? "" : ", ") + std::to_string(n) + " " + what + (n == 1 ? "" : "s");
    };
    unsigned skinned = 0;
    for (unsigned i = 0; i < scene_->mNumMeshes; ++i) skinned += scene_->mMeshes[i]->HasBones();
    add(scene_->mNumMeshes, "mesh");
    if (skinned) s += " (" + std::to_string(skinned) + " skinned)";
    add(scene_->mNumCameras, "camera");
    add(scene_->mNumLights, "light");
    return s;
  }

  using Channels = std::map<const aiNode*, const aiNodeAnim*>;

  SkeletonAnimation Sampled(const aiAnimation& anim, std::vector<std::string>* notes) const {
    const std::string label = "animation '" + std::string(anim.mName.C_Str()) + "'";
    const Channels channel = MovedNodes(anim, label, notes);
    Mat4 above;
    const aiNode* root = SkeletonRoot(channel, &above);
    SkeletonAnimation out;
    out.origin = path_;
    out.format = FormatName();
    const std::vector<const aiNode*> nodes = Skeleton(root, channel, &out.joints);
    const FrameGrid grid = KeyFrameGrid(anim, channel, label, notes);
    out.frame_time = grid.step / TicksPerSecond(anim);
    NodeTransforms rest = RestTransforms(nodes);
    out.rest = RestPose(out.joints, above, rest.local, notes);
    out.frames = SampleFrames(channel, nodes, out.joints, above, grid, std::move(rest));
    return out;
  }

  // The nodes an animation moves, with their channels.
  Channels MovedNodes(const aiAnimation& anim, const std::string& label,
                      std::vector<std::string>* notes) const {
    Channels channel;
    std::vector<std::string> unknown;
    for (unsigned c = 0; c < anim.mNumChannels; ++c) {
      const aiNodeAnim* ch = anim.mChannels[c];
      const aiNode* node = scene_->mRootNode->FindNode(ch->mNodeName);
      if (node) {
        channel[node] = ch;
      } else {
        unknown.push_back(ch->mNodeName.C_Str());
      }
    }
    if (channel.empty()) throw ConfigError(path_ + ": " + label + " moves no node of the scene");
    if (notes && !unknown.empty()) {
      notes->push_back(std::to_string(unknown.size()) + " channels name no node (first: '" +
                       unknown.front() + "'): ignored");
    }
    return channel;
  }

  // The root of the smallest subtree holding every moved node; `above` receives everything above
  // it: the file's axis and unit conventions, an armature object.
  static const aiNode* SkeletonRoot(const Channels& channel, Mat4* above) {
    auto ancestors = [](const aiNode* n) {
      std::vector<const aiNode*> chain;
      for (; n; n = n->mParent) chain.push_back(n);
      std::reverse(chain.begin(), chain.end());
      return chain;
    };
    std::vector<const aiNode*> top = ancestors(channel.begin()->first);
    for (const auto& [node, ch] : channel) {
      std::vector<const aiNode*> chain = ancestors(node);
      size_t k = 0;
      while (k < top.size() && k < chain.size() && top[k] == chain[k]) ++k;
      top.resize(k);
    }
    for (size_t k = 0; k + 1 < top.size(); ++k)
      *above = Mul(*above, FromAssimp(top[k]->mTransformation));
    return top.back();
  }

  // The skeleton's nodes below `root`, parents first, and their joints. A node belongs to the
  // skeleton unless nothing in its subtree moves and it holds a mesh, camera or light.
  std::vector<const aiNode*> Skeleton(const aiNode* root, const Channels& channel,
                                      std::vector<AnimatedJoint>* joints) const {
    std::set<std::string> other;  // cameras' and lights' nodes
    for (unsigned i = 0; i < scene_->mNumCameras; ++i)
      other.insert(scene_->mCameras[i]->mName.C_Str());
    for (unsigned i = 0; i < scene_->mNumLights; ++i)
      other.insert(scene_->mLights[i]->mName.C_Str());
    std::map<const aiNode*, bool> moves;
    auto mark = [&](auto&& self, const aiNode* n) -> bool {
      bool m = channel.count(n) > 0;
      for (unsigned c = 0; c < n->mNumChildren; ++c) m = self(self, n->mChildren[c]) || m;
      return moves[n] = m;
    };
    mark(mark, root);
    std::vector<const aiNode*> nodes;
    auto collect = [&](auto&& self, const aiNode* n, int parent) -> void {
      if (!moves[n] && (n->mNumMeshes > 0 || other.count(n->mName.C_Str()))) return;
      if (nodes.size() >= 100000) throw ConfigError(path_ + ": more than 100000 nodes");
      const int index = static_cast<int>(nodes.size());
      nodes.push_back(n);
      joints->push_back({n->mName.C_Str(), parent, false});
      for (unsigned c = 0; c < n->mNumChildren; ++c) self(self, n->mChildren[c], index);
    };
    collect(collect, root, -1);
    return nodes;
  }

  // Frame times in ticks: `frames` frames `step` apart from `start`.
  struct FrameGrid {
    double start = 0, step = 0;
    int frames = 0;
  };

  // Frame times: the keys' own spacing (the median gap between a channel's keys).
  FrameGrid KeyFrameGrid(const aiAnimation& anim, const Channels& channel, const std::string& label,
                         std::vector<std::string>* notes) const {
    const double tps = TicksPerSecond(anim);
    std::vector<double> gaps;
    double start = INFINITY, end = -INFINITY;
    auto times = [&](auto keys, unsigned n) {
      for (unsigned k = 0; k < n; ++k) {
        const double t = keys[k].mTime;
        if (!std::isfinite(t))
          throw ConfigError(path_ + ": " + label + ": a key time is not a number");
        start = std::min(start, t);
        end = std::max(end, t);
        if (k > 0 && t > keys[k - 1].mTime) gaps.push_back(t - keys[k - 1].mTime);
      }
    };
    for (const auto& [node, ch] : channel) {
      times(ch->mPositionKeys, ch->mNumPositionKeys);
      times(ch->mRotationKeys, ch->mNumRotationKeys);
      times(ch->mScalingKeys, ch->mNumScalingKeys);
    }
    if (gaps.empty() || !(end > start)) {
      throw ConfigError(path_ + ": " + label + " has no two keys apart in time: nothing moves");
    }
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    double step = gaps[gaps.size() / 2];  // ticks
    const double key_rate = tps / step;
    if (!(key_rate >= 10 && key_rate <= 1000)) {
      step = tps / 30;
      if (notes) {
        char buffer[160];
        std::snprintf(buffer, sizeof buffer,
                      "keys are %.3g per second, not one per frame: sampled at 30 frames/s",
                      key_rate);
        notes->push_back(buffer);
      }
    }
    double span = (end - start) / step;
    if (span > 1e6) throw ConfigError(path_ + ": " + label + " is longer than a million frames");
    // Key times stored as floats are a little off the frame grid: a span within 1 % of a whole
    // number of frames is that number, and the step is set to land on the last key exactly.
    if (std::abs(span - std::round(span)) < 0.01 && std::round(span) >= 1) {
      span = std::round(span);
      step = (end - start) / span;
    }
    const int frames = static_cast<int>(std::floor(span)) + 1;
    if (frames < 2) throw ConfigError(path_ + ": " + label + " is shorter than two frames");
    return {start, step, frames};
  }

  // Each node's own transform, as a matrix and decomposed: what a channel without keys of a kind
  // keeps.
  struct NodeTransforms {
    std::vector<Mat4> local;
    std::vector<Vec3> translation, scaling;
    std::vector<Quat> rotation;
  };

  static NodeTransforms RestTransforms(const std::vector<const aiNode*>& nodes) {
    NodeTransforms rest;
    rest.local.resize(nodes.size());
    rest.translation.resize(nodes.size());
    rest.scaling.resize(nodes.size());
    rest.rotation.resize(nodes.size());
    for (size_t j = 0; j < nodes.size(); ++j) {
      rest.local[j] = FromAssimp(nodes[j]->mTransformation);
      aiVector3D s, t;
      aiQuaternion r;
      nodes[j]->mTransformation.Decompose(s, r, t);
      rest.translation[j] = {t.x, t.y, t.z};
      rest.scaling[j] = {s.x, s.y, s.z};
      rest.rotation[j] = Normalized({r.w, r.x, r.y, r.z});
    }
    return rest;
  }

  // The joints' world poses for their local transforms.
  std::vector<JointPose> WorldPoses(const std::vector<AnimatedJoint>& joints, const Mat4& above,
                                    const std::vector<Mat4>& local) const {
    std::vector<Mat4> w(local.size());
    std::vector<JointPose> poses(local.size());
    for (size_t j = 0; j < local.size(); ++j) {
      const int parent = joints[j].parent;
      w[j] = Mul(parent < 0 ? above : w[parent], local[j]);
      if (!IsFinite(w[j])) {
        throw ConfigError(path_ + ": node '" + joints[j].name +
                          "' has a transform that is not finite");
      }
      poses[j] = PoseOf(w[j]);
    }
    return poses;
  }

  // Rest pose: the nodes' own transforms. Skinned meshes carry each bone's bind pose (the inverse
  // of its offset matrix, in the mesh's space): the pose the skeleton was built in, which node
  // transforms need not be (Blender writes the pose of the frame it exports from). Where there is
  // one it is the rest pose.
  std::vector<JointPose> RestPose(const std::vector<AnimatedJoint>& joints, const Mat4& above,
                                  const std::vector<Mat4>& local,
                                  std::vector<std::string>* notes) const {
    std::map<std::string, Mat4> bind;
    for (unsigned i = 0; i < scene_->mNumMeshes; ++i) {
      const aiMesh* mesh = scene_->mMeshes[i];
      if (!mesh->HasBones()) continue;
      const aiNode* holder = MeshNode(scene_->mRootNode, i);
      Mat4 mesh_world;
      for (const aiNode* n = holder; n; n = n->mParent) {
        mesh_world = Mul(FromAssimp(n->mTransformation), mesh_world);
      }
      for (unsigned b = 0; b < mesh->mNumBones; ++b) {
        aiMatrix4x4 inverse = mesh->mBones[b]->mOffsetMatrix;
        inverse.Inverse();
        const Mat4 m = Mul(mesh_world, FromAssimp(inverse));
        if (IsFinite(m)) bind.emplace(mesh->mBones[b]->mName.C_Str(), m);
      }
    }
    std::vector<Mat4> rest_world(joints.size());
    int bound = 0;
    for (size_t j = 0; j < joints.size(); ++j) {
      const int parent = joints[j].parent;
      auto it = bind.find(joints[j].name);
      if (it != bind.end()) {
        rest_world[j] = it->second;
        ++bound;
      } else {
        rest_world[j] = Mul(parent < 0 ? above : rest_world[parent], local[j]);
      }
    }
    if (bound == 0) return WorldPoses(joints, above, local);
    std::vector<JointPose> rest;
    for (size_t j = 0; j < joints.size(); ++j) rest.push_back(PoseOf(rest_world[j]));
    if (notes) {
      notes->push_back("rest pose: the skinned mesh's bind pose (" + std::to_string(bound) +
                       " of " + std::to_string(joints.size()) + " joints)");
    }
    return rest;
  }

  // The world poses at every frame of `grid`: moved nodes take their channels' keys, the others
  // stay as in the rest pose.
  std::vector<std::vector<JointPose>> SampleFrames(const Channels& channel,
                                                   const std::vector<const aiNode*>& nodes,
                                                   const std::vector<AnimatedJoint>& joints,
                                                   const Mat4& above, const FrameGrid& grid,
                                                   NodeTransforms rest) const {
    std::vector<std::vector<JointPose>> frames;
    frames.reserve(grid.frames);
    std::vector<Mat4>& local = rest.local;
    for (int f = 0; f < grid.frames; ++f) {
      const double t = grid.start + f * grid.step;
      for (size_t j = 0; j < nodes.size(); ++j) {
        auto it = channel.find(nodes[j]);
        if (it == channel.end()) continue;
        const aiNodeAnim& ch = *it->second;
        Vec3 position =
            Sample(ch.mPositionKeys, ch.mNumPositionKeys, t, rest.translation[j], LerpVec);
        Quat rotation =
            Sample(ch.mRotationKeys, ch.mNumRotationKeys, t, rest.rotation[j], SlerpQuat);
        Vec3 scale = Sample(ch.mScalingKeys, ch.mNumScalingKeys, t, rest.scaling[j], LerpVec);
        local[j] = Compose(position, rotation, scale);
      }
      frames.push_back(WorldPoses(joints, above, local));
    }
    return frames;
  }

  // The first node that draws mesh `index`, or nullptr.
  static const aiNode* MeshNode(const aiNode* node, unsigned index) {
    for (unsigned m = 0; m < node->mNumMeshes; ++m) {
      if (node->mMeshes[m] == index) return node;
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) {
      if (const aiNode* found = MeshNode(node->mChildren[c], index)) return found;
    }
    return nullptr;
  }

  std::string FormatName() const {
    std::string ext = Lower(std::filesystem::path(path_).extension().string());
    if (ext == ".fbx") return "FBX";
    if (ext == ".gltf" || ext == ".glb") return "glTF";
    if (ext == ".dae") return "COLLADA";
    if (ext == ".bvh") return "BVH (Assimp)";
    return ext.empty() ? "scene" : ext.substr(1);
  }

  std::string path_;
  Assimp::Importer importer_;
  const aiScene* scene_ = nullptr;
};

}  // namespace

std::vector<AnimationInfo> ListAnimations(const std::string& path) {
  if (IsBvh(path)) {
    BvhMotion bvh = LoadBvh(path);
    return {{"", bvh.num_frames() * bvh.frame_time, static_cast<int>(bvh.joints.size())}};
  }
  return Scene(path).Animations();
}

SkeletonAnimation LoadSkeletonAnimation(const std::string& path, const std::string& animation,
                                        std::vector<std::string>* notes, BvhReader bvh_reader) {
  if (IsBvh(path) && bvh_reader == BvhReader::kRagdoll) {
    if (!animation.empty() && animation != "0") {
      throw ConfigError(path + ": a BVH file holds one animation; no animation '" + animation +
                        "'");
    }
    BvhMotion bvh = LoadBvh(path);
    if (notes) notes->insert(notes->end(), bvh.notes.begin(), bvh.notes.end());
    return FromBvh(bvh);
  }
  return Scene(path).Load(animation, notes);
}

}  // namespace ragdoll::motion
