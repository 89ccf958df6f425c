#include "motion/retarget.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "character/skeleton.h"
#include "character/vector.h"
#include "common/config_section.h"

namespace ragdoll::motion {

using character::Add;
using character::AngleBetween;
using character::AxisAngle;
using character::Character;
using character::Conjugate;
using character::Cross;
using character::DataPtr;
using character::DecomposeHinges;
using character::Dot;
using character::FindJoint;
using character::HeadingOf;
using character::HingeAxes;
using character::Humanoid3dJoints;
using character::kIdentityQuat;
using character::MotionClip;
using character::Multiply;
using character::Norm;
using character::Normalized;
using character::Pose;
using character::Quat;
using character::Rotate;
using character::Scale;
using character::Sub;
using character::Vec3;
using character::YawOf;

namespace {

using Mat3 = std::array<Vec3, 3>;  // rows

Vec3 Apply(const Mat3& m, const Vec3& v) { return {Dot(m[0], v), Dot(m[1], v), Dot(m[2], v)}; }
Mat3 Transpose(const Mat3& m) {
  Mat3 t;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) t[i][j] = m[j][i];
  }
  return t;
}

Mat3 Mul(const Mat3& a, const Mat3& b) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) r[i][j] += a[i][k] * b[k][j];
    }
  }
  return r;
}
// A rotation matrix's quaternion (Shepperd's method).
Quat ToQuat(const Mat3& m) {
  const double trace = m[0][0] + m[1][1] + m[2][2];
  Quat q;
  if (trace > 0) {
    double s = std::sqrt(trace + 1.0) * 2;
    q = {0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    double s = std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2;
    q = {(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
  } else if (m[1][1] > m[2][2]) {
    double s = std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2;
    q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
  } else {
    double s = std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2;
    q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
  }
  return Normalized(q);
}
// The orthonormal frame whose first axis is `primary` and whose second is `secondary` made
// perpendicular to it, as the columns of a matrix.
Mat3 Frame(const Vec3& primary, const Vec3& secondary) {
  Vec3 e1 = Scale(primary, 1 / Norm(primary));
  Vec3 s = Sub(secondary, Scale(e1, Dot(secondary, e1)));
  Vec3 e2 = Scale(s, 1 / Norm(s));
  Vec3 e3 = Cross(e1, e2);
  return Transpose(Mat3{e1, e2, e3});
}
// The coordinate axis nearest to v, signed.
Vec3 Snap(const Vec3& v) {
  int best = 0;
  for (int i = 1; i < 3; ++i) {
    if (std::abs(v[i]) > std::abs(v[best])) best = i;
  }
  Vec3 axis = {0, 0, 0};
  axis[best] = v[best] > 0 ? 1 : -1;
  return axis;
}
// Reflection across the sagittal (x-z) plane, for mirroring: y -> -y.
Vec3 Mirror(const Vec3& v) { return {v[0], -v[1], v[2]}; }
Quat Mirror(const Quat& q) { return {q[0], -q[1], q[2], -q[3]}; }

const char* const kChannelNames[] = {"Xposition", "Yposition", "Zposition",
                                     "Xrotation", "Yrotation", "Zrotation"};

std::string Swapped(const std::string& part) {
  if (part.rfind("left_", 0) == 0) return "right_" + part.substr(5);
  if (part.rfind("right_", 0) == 0) return "left_" + part.substr(6);
  return part;
}

// How a segment's twist is fixed when aligning the rest poses.
enum class Twist { kHipsLeft, kShouldersLeft, kForward, kUp };

// A segment of the character: the part (joint) that rotates it, the part at the far end of its
// bone, its parent segment, its twist reference, and whether it turns on a single hinge (+y).
struct Segment {
  const char* part;
  const char* bone_end;
  int parent;
  Twist twist;
  bool hinge;
};

const Segment kSegments[] = {
    {"root", "chest", -1, Twist::kHipsLeft, false},
    {"chest", "neck", 0, Twist::kShouldersLeft, false},
    {"neck", "head", 1, Twist::kForward, false},
    {"right_hip", "right_knee", 0, Twist::kForward, false},
    {"right_knee", "right_ankle", 3, Twist::kForward, true},
    {"right_ankle", "right_toe", 4, Twist::kUp, false},
    {"right_shoulder", "right_elbow", 1, Twist::kForward, false},
    {"right_elbow", "right_wrist", 6, Twist::kForward, true},
    {"left_hip", "left_knee", 0, Twist::kForward, false},
    {"left_knee", "left_ankle", 8, Twist::kForward, true},
    {"left_ankle", "left_toe", 9, Twist::kUp, false},
    {"left_shoulder", "left_elbow", 1, Twist::kForward, false},
    {"left_elbow", "left_wrist", 11, Twist::kForward, true},
};
constexpr int kSegmentCount = sizeof(kSegments) / sizeof(kSegments[0]);

// Rest positions of the character's parts (world frame, the model's initial pose).
std::map<std::string, Vec3> CharacterRest(const Character& character) {
  const mjModel* m = character.model();
  DataPtr d = character.MakeData();
  mj_kinematics(m, d.get());
  std::map<std::string, Vec3> rest;
  auto body = [&](const std::string& name) {
    int id = character.BodyId(name);
    return Vec3{d->xpos[3 * id], d->xpos[3 * id + 1], d->xpos[3 * id + 2]};
  };
  for (const char* name : {"root", "chest", "neck", "right_hip", "right_knee", "right_ankle",
                           "right_shoulder", "right_elbow", "right_wrist", "left_hip", "left_knee",
                           "left_ankle", "left_shoulder", "left_elbow", "left_wrist"}) {
    rest[name] = body(name);
  }
  // Points the model has no body for: the top of the head and the toes of a flat foot.
  rest["head"] = Add(rest["neck"], {0, 0, 0.2});
  rest["right_toe"] = Add(rest["right_ankle"], {0.15, 0, 0});
  rest["left_toe"] = Add(rest["left_ankle"], {0.15, 0, 0});
  return rest;
}

// The source skeleton as the character sees it: which source joint drives each part (after
// mirroring, a left part reads the right joint) and the axes that take the source's coordinates
// to the character's (x forward, y left, z up), found from its rest pose.
class SourceOnCharacter {
 public:
  SourceOnCharacter(const SkeletonAnimation& source, const JointMapping& mapping,
                    const ImportOptions& options, std::vector<std::string>* warnings)
      : source_(source), mirror_(options.mirror) {
    MapJoints(mapping, warnings);
    for (const JointPose& p : source.rest) rest_position_.push_back(p.position);
    FindAxes();
  }

  const SkeletonAnimation& source() const { return source_; }
  bool has(const std::string& part) const { return joint_.count(part) > 0; }
  int joint(const std::string& part) const { return joint_.at(part); }
  const Vec3& rest_position(int j) const { return rest_position_[j]; }

  // The far end of a part's bone: the mapped part, else the joint's first child.
  int BoneEnd(const std::string& part, const std::string& end) const {
    if (has(end)) return joint(end);
    if (!has(part)) return -1;
    for (size_t c = 0; c < source_.joints.size(); ++c) {
      if (source_.joints[c].parent == joint(part)) return static_cast<int>(c);
    }
    return -1;
  }
  // A source position in the character's coordinates (mirrored if asked).
  Vec3 InCharacter(const Vec3& v) const {
    Vec3 c = Apply(to_character_, v);
    return mirror_ ? Mirror(c) : c;
  }
  // A joint's rotation at a frame relative to its rest, in the character's coordinates.
  Quat WorldAt(int f, int j) const {
    Quat q = Multiply(source_.frames[f][j].rotation, Conjugate(source_.rest[j].rotation));
    Quat world = Multiply(Multiply(to_character_q_, q), from_character_q_);
    return mirror_ ? Mirror(world) : world;
  }

 private:
  void MapJoints(const JointMapping& mapping, std::vector<std::string>* warnings) {
    auto root = mapping.joints.find("root");
    if (root == mapping.joints.end() || source_.Find(root->second) < 0) {
      ThrowConfigError(source_.origin,
                       "joint '" + (root == mapping.joints.end() ? std::string() : root->second) +
                           "' (mapped to root in " + mapping.origin + ") is not in the file");
    }
    for (const auto& [part, name] : mapping.joints) {
      int j = source_.Find(name);
      if (j < 0) {
        // A part the file lacks stays at rest (or, for bone ends, the joint's child is used).
        if (warnings) {
          warnings->push_back("joint '" + name + "' (" + part + ") is not in the file; " + part +
                              " stays at rest");
        }
        continue;
      }
      joint_[mirror_ ? Swapped(part) : part] = j;
    }
    if (!has("root")) ThrowConfigError(source_.origin, "the mapping does not name the root joint");
  }

  // Up from the root to the top of the spine, left from the right hip (or shoulder) to the left.
  void FindAxes() {
    Vec3 up_raw = {0, 0, 0};
    for (const char* top : {"neck", "chest", "head"}) {
      if (has(top)) {
        up_raw = Sub(rest_position_[joint(top)], rest_position_[joint("root")]);
        if (Norm(up_raw) > 0) break;
      }
    }
    if (!(Norm(up_raw) > 0))
      ThrowConfigError(source_.origin, "cannot find the up direction: map chest, neck or head");
    Vec3 left_raw = {0, 0, 0};
    if (has("left_hip") && has("right_hip")) {
      left_raw = Sub(rest_position_[joint("left_hip")], rest_position_[joint("right_hip")]);
    } else if (has("left_shoulder") && has("right_shoulder")) {
      left_raw =
          Sub(rest_position_[joint("left_shoulder")], rest_position_[joint("right_shoulder")]);
    }
    if (mirror_) left_raw = Scale(left_raw, -1);
    const Vec3 up = Snap(up_raw);
    left_raw = Sub(left_raw, Scale(up, Dot(left_raw, up)));
    if (!(Norm(left_raw) > 0)) {
      ThrowConfigError(source_.origin,
                       "cannot find left and right: map both hips or both shoulders");
    }
    const Vec3 left = Snap(left_raw);
    const Vec3 forward = Cross(left, up);
    to_character_ = {forward, left, up};
    to_character_q_ = ToQuat(to_character_);
    from_character_q_ = Conjugate(to_character_q_);
  }

  const SkeletonAnimation& source_;
  const bool mirror_;
  std::map<std::string, int> joint_;
  std::vector<Vec3> rest_position_;
  Mat3 to_character_;
  Quat to_character_q_, from_character_q_;
};

// Metres per source unit: the character's leg length over the source's, hip to knee to ankle.
double LegLengthScale(const SourceOnCharacter& view, const std::map<std::string, Vec3>& char_rest) {
  double source_leg = 0, char_leg = 0;
  for (const char* side : {"right_", "left_"}) {
    const std::string hip = std::string(side) + "hip", knee = std::string(side) + "knee",
                      ankle = std::string(side) + "ankle";
    if (view.has(hip) && view.has(knee) && view.has(ankle)) {
      source_leg +=
          Norm(Sub(view.rest_position(view.joint(hip)), view.rest_position(view.joint(knee)))) +
          Norm(Sub(view.rest_position(view.joint(knee)), view.rest_position(view.joint(ankle))));
      char_leg += Norm(Sub(char_rest.at(hip), char_rest.at(knee))) +
                  Norm(Sub(char_rest.at(knee), char_rest.at(ankle)));
    }
  }
  if (!(source_leg > 0)) {
    ThrowConfigError(view.source().origin,
                     "cannot find the leg length to scale by: map hips, knees and ankles");
  }
  return char_leg / source_leg;
}

// Per segment: whether a source joint drives it, and the rotation taking the character's rest
// segment frame onto the source's.
struct SegmentAlignments {
  std::vector<Quat> alignment = std::vector<Quat>(kSegmentCount, kIdentityQuat);
  std::vector<bool> driven = std::vector<bool>(kSegmentCount, false);
};

// Rest alignment of each segment: the rotation taking the character's rest segment frame (bone
// direction, twist reference) onto the source's.
SegmentAlignments AlignRestPoses(const SourceOnCharacter& view,
                                 const std::map<std::string, Vec3>& char_rest) {
  SegmentAlignments aligned;
  for (int s = 0; s < kSegmentCount; ++s) {
    const Segment& seg = kSegments[s];
    if (!view.has(seg.part)) continue;
    aligned.driven[s] = true;
    int end = view.BoneEnd(seg.part, seg.bone_end);
    if (end < 0) continue;  // no bone to align: rest frames taken as equal
    Vec3 source_bone =
        view.InCharacter(Sub(view.rest_position(end), view.rest_position(view.joint(seg.part))));
    Vec3 char_bone = Sub(char_rest.at(seg.bone_end), char_rest.at(seg.part));
    if (!(Norm(source_bone) > 1e-9)) continue;
    Vec3 source_twist = {1, 0, 0}, char_twist = {1, 0, 0};
    auto pair = [&](const char* l, const char* r) {
      if (view.has(l) && view.has(r)) {
        source_twist = view.InCharacter(
            Sub(view.rest_position(view.joint(l)), view.rest_position(view.joint(r))));
        char_twist = Sub(char_rest.at(l), char_rest.at(r));
      }
    };
    if (seg.twist == Twist::kHipsLeft) pair("left_hip", "right_hip");
    if (seg.twist == Twist::kShouldersLeft) pair("left_shoulder", "right_shoulder");
    if (seg.twist == Twist::kUp) source_twist = char_twist = {0, 0, 1};
    auto across = [](const Vec3& bone, const Vec3& t) {
      return Norm(Sub(t, Scale(bone, Dot(t, bone) / Dot(bone, bone)))) >= 0.3 * Norm(t);
    };
    // A twist reference along the bone fixes nothing: use a world axis across both bones (a file
    // whose "rest" is a posed frame can hold a shin level while the character's hangs).
    if (!across(source_bone, source_twist) || !across(char_bone, char_twist)) {
      const Vec3 up = {0, 0, 1}, forward = {1, 0, 0}, left = {0, 1, 0};
      for (const Vec3& axis : seg.twist == Twist::kUp ? std::array{forward, up, left}
                                                      : std::array{up, forward, left}) {
        if (across(source_bone, axis) && across(char_bone, axis)) {
          source_twist = char_twist = axis;
          break;
        }
      }
    }
    aligned.alignment[s] =
        ToQuat(Mul(Frame(source_bone, source_twist), Transpose(Frame(char_bone, char_twist))));
  }
  return aligned;
}

// Hinges from the motion: a knee or elbow bends about one axis, fixed in the thigh or upper
// arm. Where the motion bends it enough to show that axis, the thigh's or upper arm's twist
// (and the shin's or forearm's) is chosen so that the character's hinge lies along it. The rest
// pose's twist is then not needed: files whose node transforms hold a bent pose rather than
// the rest (Blender's exports of a bare armature) bend their knees and elbows as they should.
void AlignHingesWithMotion(const SourceOnCharacter& view, const Character& character,
                           const std::map<std::string, Vec3>& char_rest,
                           const ImportOptions& options, SegmentAlignments* aligned) {
  const SkeletonAnimation& source = view.source();
  std::vector<Quat>& alignment = aligned->alignment;
  const int first = std::max(options.first_frame, 0);
  const int end = options.last_frame < 0 ? source.num_frames() - 1
                                         : std::min(options.last_frame, source.num_frames() - 1);
  const mjModel* m = character.model();
  for (int h = 0; h < kSegmentCount; ++h) {
    const Segment& seg = kSegments[h];
    if (!seg.hinge || !aligned->driven[h] || !aligned->driven[seg.parent]) continue;
    const Segment& parent = kSegments[seg.parent];
    const int a = view.joint(parent.part), b = view.joint(seg.part),
              c = view.BoneEnd(seg.part, seg.bone_end);
    if (c < 0) continue;
    // The source's bend axis in each segment's rest-relative frame, averaged over the frames
    // bent by more than 20 degrees.
    Vec3 axis_parent = {0, 0, 0}, axis_child = {0, 0, 0};
    int bent = 0;
    for (int f = first; f <= end; ++f) {
      const auto& pose = source.frames[f];
      const Vec3 u = view.InCharacter(Sub(pose[b].position, pose[a].position));
      const Vec3 w = view.InCharacter(Sub(pose[c].position, pose[b].position));
      const Vec3 n = Cross(u, w);
      if (!(Norm(n) > std::sin(20 * M_PI / 180) * Norm(u) * Norm(w))) continue;
      const Vec3 unit = Scale(n, 1 / Norm(n));
      axis_parent = Add(axis_parent, Rotate(Conjugate(view.WorldAt(f, a)), unit));
      axis_child = Add(axis_child, Rotate(Conjugate(view.WorldAt(f, b)), unit));
      ++bent;
    }
    // Too few bent frames, or an axis that wanders (not a hinge): the rest pose decides.
    if (bent < 10 || Norm(axis_parent) < 0.8 * bent || Norm(axis_child) < 0.8 * bent) continue;
    // The character's bend axis at rest: its bone directions with the hinge flexed.
    const int hinge = m->body_jntadr[character.BodyId(seg.part)];
    const double* range = m->jnt_range + 2 * hinge;
    const double flex = std::abs(range[1]) >= std::abs(range[0]) ? 0.5 : -0.5;
    const Vec3 hinge_axis = {m->jnt_axis[3 * hinge], m->jnt_axis[3 * hinge + 1],
                             m->jnt_axis[3 * hinge + 2]};
    const Vec3 char_u = Sub(char_rest.at(seg.part), char_rest.at(parent.part));
    const Vec3 char_w = Sub(char_rest.at(seg.bone_end), char_rest.at(seg.part));
    const Vec3 char_axis = Cross(char_u, Rotate(AxisAngle(hinge_axis, flex), char_w));
    if (!(Norm(char_axis) > 1e-9)) continue;
    // Turn each alignment about its bone until the hinge lies along the source's axis.
    auto twist_onto = [&](int s, const Vec3& char_bone, const Vec3& target) {
      const Vec3 bone = Rotate(alignment[s], Scale(char_bone, 1 / Norm(char_bone)));
      const Vec3 from = Rotate(alignment[s], char_axis);
      auto flat = [&](const Vec3& v) { return Sub(v, Scale(bone, Dot(v, bone))); };
      const Vec3 x = flat(from), y = flat(target);
      if (!(Norm(x) > 1e-9 && Norm(y) > 1e-9)) return;
      const double angle = std::atan2(Dot(bone, Cross(x, y)), Dot(x, y));
      alignment[s] = Normalized(Multiply(AxisAngle(bone, angle), alignment[s]));
    };
    twist_onto(seg.parent, char_u, axis_parent);
    twist_onto(h, char_w, axis_child);
  }
}

// Feet: align each from the frames where the source's own foot is planted (ankle and toe near
// their lowest, toe nearly still), so that a foot flat on the floor in the capture is flat on
// the character's floor: the alignment that makes the character's foot level in those frames,
// keeping the heading the rest alignment gives it.
// A toe moving faster than this (m/s) is not planted.
constexpr double kPlantedToeSpeed = 0.3;

// One foot of the source on the character: its ankle and toe joints, and which frames it is
// low in (toe and ankle within 3 cm of their 1st-percentile heights: a glitch frame is not the
// floor). `valid` is false when the source lacks the ankle or its toe.
struct SourceFoot {
  bool valid = false;
  int ankle = -1, toe = -1;
  std::vector<char> low;  // [frame - first]
};

SourceFoot FindSourceFoot(const SourceOnCharacter& view, const std::string& side, int first,
                          int last, double scale) {
  SourceFoot foot;
  const std::string ankle = side + "ankle";
  foot.toe = view.BoneEnd(ankle, side + "toe");
  if (!view.has(ankle) || foot.toe < 0 || last < first) return foot;
  foot.ankle = view.joint(ankle);
  const SkeletonAnimation& source = view.source();
  auto height = [&](int f, int j) {
    return view.InCharacter(source.frames[f][j].position)[2] * scale;
  };
  std::vector<double> toe_heights, ankle_heights;
  for (int f = first; f <= last; ++f) {
    toe_heights.push_back(height(f, foot.toe));
    ankle_heights.push_back(height(f, foot.ankle));
  }
  std::vector<double> toe_sorted = toe_heights, ankle_sorted = ankle_heights;
  std::sort(toe_sorted.begin(), toe_sorted.end());
  std::sort(ankle_sorted.begin(), ankle_sorted.end());
  const double toe_min = toe_sorted[toe_sorted.size() / 100];
  const double ankle_min = ankle_sorted[ankle_sorted.size() / 100];
  for (size_t i = 0; i < toe_heights.size(); ++i) {
    foot.low.push_back(toe_heights[i] <= toe_min + 0.03 && ankle_heights[i] <= ankle_min + 0.03);
  }
  foot.valid = true;
  return foot;
}

// The horizontal velocity of the frames' low toes, per component the median over both feet
// (`low`: the toe and ankle within 3 cm of their floors). Zero for a clip whose planted feet
// stand still; the walking speed backward for one exported in place (a treadmill).
Vec3 TreadmillVelocity(const SourceOnCharacter& view, int first, int last, double scale) {
  const SkeletonAnimation& source = view.source();
  const double dt = source.frame_time > 0 ? source.frame_time : 1.0 / 30;
  std::vector<double> vx, vy;
  for (const char* side : {"right_", "left_"}) {
    const SourceFoot foot = FindSourceFoot(view, side, first, last, scale);
    if (!foot.valid) continue;
    for (int f = first; f < last; ++f) {
      if (!foot.low[f - first]) continue;
      const Vec3 step = Scale(Sub(view.InCharacter(source.frames[f + 1][foot.toe].position),
                                  view.InCharacter(source.frames[f][foot.toe].position)),
                              scale / dt);
      vx.push_back(step[0]);
      vy.push_back(step[1]);
    }
  }
  if (vx.empty()) return {0, 0, 0};
  std::nth_element(vx.begin(), vx.begin() + vx.size() / 2, vx.end());
  std::nth_element(vy.begin(), vy.begin() + vy.size() / 2, vy.end());
  return {vx[vx.size() / 2], vy[vy.size() / 2], 0};
}

void LevelFeet(const SourceOnCharacter& view, int first, int last, double scale,
               SegmentAlignments* aligned, std::vector<std::string>* warnings) {
  const SkeletonAnimation& source = view.source();
  // Planted toes are still against the floor, or, in a clip exported in place, against the
  // treadmill its planted feet slide on: toe speeds are measured against that when it moves
  // faster than a planted toe may (any other clip keeps zero).
  Vec3 treadmill = TreadmillVelocity(view, first, last, scale);
  if (std::hypot(treadmill[0], treadmill[1]) <= kPlantedToeSpeed) treadmill = {0, 0, 0};
  for (const char* side : {"right_", "left_"}) {
    const int s = side[0] == 'r' ? 5 : 10;
    const SourceFoot foot = FindSourceFoot(view, side, first, last, scale);
    if (!foot.valid || !aligned->driven[s]) continue;
    const int a = foot.ankle, toe = foot.toe;
    const double dt = source.frame_time > 0 ? source.frame_time : 1.0 / 30;
    Quat sum = {0, 0, 0, 0};
    int planted = 0;
    for (int f = first; f <= last; ++f) {
      if (!foot.low[f - first]) continue;
      const int g = f < last ? f + 1 : f - 1;
      Vec3 step = Scale(Sub(view.InCharacter(source.frames[g][toe].position),
                            view.InCharacter(source.frames[f][toe].position)),
                        scale);
      const double slide = std::hypot(step[0] / dt - treadmill[0], step[1] / dt - treadmill[1]);
      if (slide > kPlantedToeSpeed) continue;  // the toe slides or swings
      const Quat world = view.WorldAt(f, a);
      const Quat level = HeadingOf(Multiply(world, aligned->alignment[s]));
      Quat candidate = Normalized(Multiply(Conjugate(world), level));
      double same_side = 0;  // q and -q are one rotation: add them on one side
      for (int i = 0; i < 4; ++i) same_side += sum[i] * candidate[i];
      if (same_side < 0) {
        for (double& x : candidate) x = -x;
      }
      for (int i = 0; i < 4; ++i) sum[i] += candidate[i];
      ++planted;
    }
    char line[200];
    if (planted < 3) {
      std::snprintf(line, sizeof line,
                    "%sfoot: planted in %d frames, too few to level it: aligned from the rest "
                    "pose",
                    side, planted);
      if (warnings) warnings->push_back(line);
      continue;
    }
    const Quat floor_alignment = Normalized(sum);
    const double turn = AngleBetween(aligned->alignment[s], floor_alignment) * 180 / M_PI;
    if (turn > 60) {
      std::snprintf(line, sizeof line,
                    "%sfoot: levelling it on its %d planted frames would turn it %.0f degrees: "
                    "kept the rest pose's alignment",
                    side, planted, turn);
    } else {
      std::snprintf(line, sizeof line,
                    "%sfoot: levelled on its %d planted frames (%.1f degrees from the rest pose)",
                    side, planted, turn);
      aligned->alignment[s] = floor_alignment;
    }
    if (warnings) warnings->push_back(line);
  }
}

// The character's poses over frames first..last: each driven segment takes its source joint's
// world rotation composed with its alignment; the others stay at rest relative to their parent.
std::vector<Pose> PoseFrames(const SourceOnCharacter& view, const SegmentAlignments& aligned,
                             int first, int last, double scale) {
  const SkeletonAnimation& source = view.source();
  const auto& skeleton = Humanoid3dJoints();
  std::vector<Pose> frames;
  for (int f = first; f <= last; ++f) {
    std::vector<Quat> global(kSegmentCount, kIdentityQuat);
    Pose pose;
    pose.joint_rotations.assign(skeleton.size(), kIdentityQuat);
    for (int s = 0; s < kSegmentCount; ++s) {
      const Segment& seg = kSegments[s];
      const Quat parent = seg.parent < 0 ? kIdentityQuat : global[seg.parent];
      if (!aligned.driven[s]) {
        global[s] = parent;  // stays at rest relative to its parent
        continue;
      }
      Quat g = Normalized(Multiply(view.WorldAt(f, view.joint(seg.part)), aligned.alignment[s]));
      if (s == 0) {
        global[s] = g;
        continue;
      }
      Quat local = Normalized(Multiply(Conjugate(parent), g));
      if (seg.hinge) {  // keep only the turn about the hinge (y): swing-twist decomposition
        double angle = 2 * std::atan2(local[2], local[0]);
        local = AxisAngle({0, 1, 0}, angle);
      }
      global[s] = Normalized(Multiply(parent, local));
      pose.joint_rotations[FindJoint(seg.part)] = local;
    }
    pose.root_rotation = global[0];
    pose.root_position =
        Scale(view.InCharacter(source.frames[f][view.joint("root")].position), scale);
    frames.push_back(std::move(pose));
  }
  return frames;
}

// Normalise: start at the origin facing +x, the feet on the floor. The floor is where the feet
// are lowest, not the lowest point of anything: a capture whose hands reach the ground with the
// source's longer arms would otherwise float the character's standing feet (the other bodies'
// penetration is what `inspect` reports). The lowest 1 % of frames is left out, as capture
// glitches.
void PlaceOnFloor(const Character& character, std::vector<Pose>* frames) {
  const Vec3 start = frames->front().root_position;
  const Quat heading = AxisAngle({0, 0, 1}, -YawOf(frames->front().root_rotation));
  for (Pose& p : *frames) {
    p.root_rotation = Normalized(Multiply(heading, p.root_rotation));
    p.root_position = Rotate(heading, Sub(p.root_position, {start[0], start[1], 0}));
  }
  const std::vector<int> feet = {character.BodyId("right_ankle"), character.BodyId("left_ankle")};
  std::vector<double> foot_heights;
  for (const Pose& p : *frames) foot_heights.push_back(character.LowestPoint(p, feet));
  std::sort(foot_heights.begin(), foot_heights.end());
  const double floor_height = foot_heights[foot_heights.size() / 100];
  for (Pose& p : *frames) p.root_position[2] -= floor_height;
}

// The hinge order of --rotation-order (three of X, Y, Z, each once) and its BVH channels.
HingeAxes RotationOrder(const std::string& rotation_order,
                        std::vector<BvhChannel>* rotation_channels) {
  if (rotation_order.size() != 3) {
    throw ConfigError("rotation order '" + rotation_order + "': three of X, Y, Z");
  }
  HingeAxes order;
  order.count = 3;
  for (int i = 0; i < 3; ++i) {
    char c = static_cast<char>(std::toupper(static_cast<unsigned char>(rotation_order[i])));
    if (c < 'X' || c > 'Z') {
      throw ConfigError("rotation order '" + rotation_order + "': three of X, Y, Z");
    }
    order.axis[i] = c - 'X';
    order.sign[i] = 1;
    rotation_channels->push_back(
        static_cast<BvhChannel>(static_cast<int>(BvhChannel::kXrotation) + (c - 'X')));
  }
  if (order.axis[0] == order.axis[1] || order.axis[1] == order.axis[2] ||
      order.axis[0] == order.axis[2]) {
    throw ConfigError("rotation order '" + rotation_order + "': each axis once");
  }
  return order;
}

void CheckUniformFrameTimes(const MotionClip& clip) {
  for (int f = 1; f + 1 < clip.num_frames(); ++f) {
    if (std::abs(clip.frame_duration(f) - clip.frame_duration(0)) > 1e-6) {
      throw ConfigError("clip '" + clip.name() + "': BVH needs uniform frame times (frame " +
                        std::to_string(f) + " differs)");
    }
  }
}

// The character's rest positions, with the end sites' (head top, fingers, toe tips) added.
std::map<std::string, Vec3> RestWithEndSites(const Character& character) {
  std::map<std::string, Vec3> rest = CharacterRest(character);
  rest["head_top"] = Add(rest["head"], {0, 0, 0.1});
  for (const char* side : {"right_", "left_"}) {
    const std::string s = side;
    rest[s + "fingers"] = Add(rest[s + "wrist"], {0, 0, -0.08});
    rest[s + "toe_tip"] = Add(rest[s + "toe"], {0.05, 0, 0});
  }
  return rest;
}

// Builds a BVH hierarchy joint by joint (a parent before its children): offsets from the rest
// positions in BVH axes, position channels on the root, no channels on end sites.
struct BvhHierarchy {
  BvhMotion& bvh;
  const std::map<std::string, Vec3>& rest;
  const Mat3& to_bvh;
  const JointMapping& naming;
  const std::vector<BvhChannel>& rotation_channels;
  double units_per_metre;
  std::map<std::string, int> index = {};
  std::vector<std::string> part_of = {};  // per BVH joint

  std::string NameOf(const std::string& part) const {
    auto it = naming.joints.find(part);
    return it == naming.joints.end() ? part : it->second;
  }

  void Add(const std::string& part, const std::string& parent, bool end_site) {
    BvhJoint j;
    j.end_site = end_site;
    j.name = end_site ? NameOf(parent) + "_end" : NameOf(part);
    j.parent = parent.empty() ? -1 : index.at(parent);
    if (!parent.empty()) {
      j.offset = Scale(Apply(to_bvh, Sub(rest.at(part), rest.at(parent))), units_per_metre);
    }
    j.first_channel = bvh.channel_count;
    if (!end_site) {
      if (parent.empty()) {
        j.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
      }
      j.channels.insert(j.channels.end(), rotation_channels.begin(), rotation_channels.end());
      bvh.channel_count += static_cast<int>(j.channels.size());
      index[part] = static_cast<int>(bvh.joints.size());
    }
    bvh.joints.push_back(j);
    part_of.push_back(part);
  }
};

void AddHumanoid(BvhHierarchy& hierarchy) {
  hierarchy.Add("root", "", false);
  // Head, hands and toes are joints (as in mocap files) that never turn, each with an end site.
  hierarchy.Add("chest", "root", false);
  hierarchy.Add("neck", "chest", false);
  hierarchy.Add("head", "neck", false);
  hierarchy.Add("head_top", "head", true);
  for (const char* side : {"right_", "left_"}) {
    const std::string s = side;
    hierarchy.Add(s + "shoulder", "chest", false);
    hierarchy.Add(s + "elbow", s + "shoulder", false);
    hierarchy.Add(s + "wrist", s + "elbow", false);
    hierarchy.Add(s + "fingers", s + "wrist", true);
  }
  for (const char* side : {"right_", "left_"}) {
    const std::string s = side;
    hierarchy.Add(s + "hip", "root", false);
    hierarchy.Add(s + "knee", s + "hip", false);
    hierarchy.Add(s + "ankle", s + "knee", false);
    hierarchy.Add(s + "toe", s + "ankle", false);
    hierarchy.Add(s + "toe_tip", s + "toe", true);
  }
}

// One frame's channel values: the root's position, then each joint's rotation as `order`'s
// angles in degrees, in BVH axes.
std::vector<double> BvhFrame(const BvhMotion& bvh, const std::vector<std::string>& part_of,
                             const Pose& pose, const HingeAxes& order, const Mat3& to_bvh,
                             const Quat& to_bvh_q, double units_per_metre) {
  auto rotation_in_bvh = [&](const Quat& q) {
    return Normalized(Multiply(Multiply(to_bvh_q, q), Conjugate(to_bvh_q)));
  };
  constexpr double kDegrees = 180.0 / M_PI;
  std::vector<double> values;
  values.reserve(bvh.channel_count);
  for (size_t ji = 0; ji < bvh.joints.size(); ++ji) {
    const BvhJoint& j = bvh.joints[ji];
    if (j.end_site) continue;
    Quat local;
    if (j.parent < 0) {
      Vec3 p = Scale(Apply(to_bvh, pose.root_position), units_per_metre);
      values.insert(values.end(), p.begin(), p.end());
      local = pose.root_rotation;
    } else {
      const int skeleton_joint = FindJoint(part_of[ji]);
      local = skeleton_joint < 0 ? kIdentityQuat : pose.joint_rotations[skeleton_joint];
    }
    double angles[3];
    DecomposeHinges(order, rotation_in_bvh(local), angles);
    for (double a : angles) values.push_back(a * kDegrees);
  }
  return values;
}

}  // namespace

MotionClip Resampled(const MotionClip& clip, double fps) {
  const int intervals = std::max(1, static_cast<int>(std::lround(clip.duration() * fps)));
  const double dt = clip.duration() / intervals;
  std::vector<Pose> resampled;
  for (int k = 0; k <= intervals; ++k)
    resampled.push_back(clip.Sample(std::min(k * dt, clip.duration())));
  std::vector<double> resampled_durations(resampled.size(), dt);
  return MotionClip(clip.name(), clip.loop(), std::move(resampled_durations), std::move(resampled));
}

const std::vector<std::string>& MappingParts() {
  static const std::vector<std::string> kParts = {
      "root",        "chest",      "neck",           "head",          "right_hip",   "right_knee",
      "right_ankle", "right_toe",  "right_shoulder", "right_elbow",   "right_wrist", "left_hip",
      "left_knee",   "left_ankle", "left_toe",       "left_shoulder", "left_elbow",  "left_wrist"};
  return kParts;
}

JointMapping ReadJointMapping(const std::string& preset_or_path) {
  namespace fs = std::filesystem;
  std::string path = preset_or_path;
  const fs::path presets = fs::path(RAGDOLL_ASSETS_DIR) / "mappings";
  if (path.find('/') == std::string::npos && fs::path(path).extension().empty()) {
    path = (presets / (path + ".yaml")).string();
    if (!fs::exists(path)) {
      std::string names;
      if (fs::is_directory(presets)) {
        for (const auto& e : fs::directory_iterator(presets)) {
          names += (names.empty() ? "" : ", ") + e.path().stem().string();
        }
      }
      throw ConfigError("no joint mapping preset '" + preset_or_path + "' (presets: " + names +
                        "; or give a YAML file)");
    }
  }
  ConfigSection section = ConfigSection::FromFile(path);
  JointMapping mapping;
  mapping.origin = path;
  for (const std::string& part : MappingParts()) {
    std::string name = section.Get<std::string>(part, "");
    if (!name.empty()) mapping.joints[part] = name;
  }
  section.Finish();
  if (!mapping.joints.count("root")) section.Fail("root", "every mapping names the root joint");
  return mapping;
}

MotionClip Retarget(const SkeletonAnimation& source, const JointMapping& mapping,
                    const Character& character, const ImportOptions& options,
                    std::vector<std::string>* warnings) {
  const SourceOnCharacter view(source, mapping, options, warnings);
  const std::map<std::string, Vec3> char_rest = CharacterRest(character);
  const double scale = options.scale > 0 ? options.scale : LegLengthScale(view, char_rest);
  SegmentAlignments aligned = AlignRestPoses(view, char_rest);
  AlignHingesWithMotion(view, character, char_rest, options, &aligned);
  const int last = options.last_frame < 0 ? source.num_frames() - 1 : options.last_frame;
  if (options.first_frame < 0 || last >= source.num_frames() || last - options.first_frame < 1) {
    ThrowConfigError(source.origin, "frame range " + std::to_string(options.first_frame) + ".." +
                                        std::to_string(last) +
                                        " needs at least two of the file's " +
                                        std::to_string(source.num_frames()) + " frames");
  }
  if (options.feet == ImportOptions::Feet::kFloor) {
    LevelFeet(view, options.first_frame, last, scale, &aligned, warnings);
  }
  std::vector<Pose> frames = PoseFrames(view, aligned, options.first_frame, last, scale);
  PlaceOnFloor(character, &frames);

  std::string name =
      options.name.empty() ? std::filesystem::path(source.origin).stem().string() : options.name;
  std::vector<double> durations(frames.size(), source.frame_time);
  MotionClip clip(name, options.loop, durations, frames);
  if (!(options.fps > 0)) return clip;
  return Resampled(clip, options.fps);
}

BvhMotion ClipToBvh(const MotionClip& clip, const Character& character, const JointMapping& naming,
                    const ExportOptions& options) {
  std::vector<BvhChannel> rotation_channels;
  const HingeAxes order = RotationOrder(options.rotation_order, &rotation_channels);
  CheckUniformFrameTimes(clip);
  // Character coordinates -> BVH: Y-up puts forward on +z, left on +x, up on +y.
  const Mat3 to_bvh = options.y_up ? Mat3{Vec3{0, 1, 0}, Vec3{0, 0, 1}, Vec3{1, 0, 0}}
                                   : Mat3{Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  const Quat to_bvh_q = ToQuat(to_bvh);
  const std::map<std::string, Vec3> rest = RestWithEndSites(character);
  BvhMotion bvh;
  bvh.origin = clip.name() + ".bvh";
  bvh.frame_time = clip.frame_duration(0);
  BvhHierarchy hierarchy{bvh, rest, to_bvh, naming, rotation_channels, options.units_per_metre};
  AddHumanoid(hierarchy);
  for (int f = 0; f < clip.num_frames(); ++f) {
    bvh.frames.push_back(BvhFrame(bvh, hierarchy.part_of, clip.frame(f), order, to_bvh, to_bvh_q,
                                  options.units_per_metre));
  }
  return bvh;
}

std::string FormatBvh(const BvhMotion& bvh) {
  std::ostringstream out;
  out.precision(6);
  out << std::fixed;
  out << "HIERARCHY\n";
  // Children of each joint, in order.
  std::vector<std::vector<int>> children(bvh.joints.size());
  for (size_t j = 0; j < bvh.joints.size(); ++j) {
    if (bvh.joints[j].parent >= 0) children[bvh.joints[j].parent].push_back(static_cast<int>(j));
  }
  auto write = [&](auto&& self, int j, int depth) -> void {
    const BvhJoint& joint = bvh.joints[j];
    const std::string indent(depth * 2, ' ');
    if (joint.end_site) {
      out << indent << "End Site\n";
    } else {
      out << indent << (joint.parent < 0 ? "ROOT " : "JOINT ") << joint.name << "\n";
    }
    out << indent << "{\n";
    out << indent << "  OFFSET " << joint.offset[0] << " " << joint.offset[1] << " "
        << joint.offset[2] << "\n";
    if (!joint.end_site) {
      out << indent << "  CHANNELS " << joint.channels.size();
      for (BvhChannel c : joint.channels) out << " " << kChannelNames[static_cast<int>(c)];
      out << "\n";
    }
    for (int c : children[j]) self(self, c, depth + 1);
    out << indent << "}\n";
  };
  write(write, 0, 0);
  out << "MOTION\nFrames: " << bvh.frames.size() << "\n";
  out.precision(8);
  out << "Frame Time: " << bvh.frame_time << "\n";
  out.precision(6);
  for (const auto& frame : bvh.frames) {
    for (size_t i = 0; i < frame.size(); ++i) out << (i ? " " : "") << frame[i];
    out << "\n";
  }
  return out.str();
}

}  // namespace ragdoll::motion
