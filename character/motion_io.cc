#include "character/motion_io.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include "character/skeleton.h"
#include "common/config_section.h"

namespace ragdoll::character {
namespace {

using nlohmann::json;

constexpr const char* kFormatName = "ragdoll-clip";
constexpr int kFormatVersion = 1;

double Number(const json& value, const std::string& origin, const std::string& where) {
  if (!value.is_number())
    ThrowConfigError(origin, where + ": expected a number, got " + value.dump());
  double x = value.get<double>();
  if (!std::isfinite(x)) ThrowConfigError(origin, where + ": not a finite number");
  return x;
}

template <size_t N>
std::array<double, N> Numbers(const json& value, const std::string& origin,
                              const std::string& where) {
  if (!value.is_array() || value.size() != N) {
    ThrowConfigError(origin,
                     where + ": expected " + std::to_string(N) + " numbers, got " + value.dump());
  }
  std::array<double, N> out;
  for (size_t i = 0; i < N; ++i) out[i] = Number(value[i], origin, where);
  return out;
}

MotionClip Build(const std::string& origin, const std::string& name, bool loop,
                 std::vector<double> durations, std::vector<Pose> frames, CycleTransform cycle) {
  try {
    return MotionClip(name, loop, std::move(durations), std::move(frames), cycle);
  } catch (const std::invalid_argument& e) {
    ThrowConfigError(origin, e.what());
  }
}

// DeepMimic: {"Loop": "wrap"|"none", "Frames": [[duration, root pos (3), root quat (4),
// then per joint a quaternion (spherical) or an angle (revolute)], ...]}.
MotionClip ParseDeepMimic(const json& doc, const std::string& origin) {
  const auto& joints = Humanoid3dJoints();
  bool loop = false;
  if (doc.contains("Loop")) {
    const json& l = doc["Loop"];
    if (!l.is_string() || (l != "wrap" && l != "none")) {
      ThrowConfigError(origin, "Loop: expected \"wrap\" or \"none\", got " + l.dump());
    }
    loop = l == "wrap";
  }
  const json& raw = doc["Frames"];
  if (!raw.is_array()) ThrowConfigError(origin, "Frames: expected a list of frames");
  size_t expected = 1 + 3 + 4;
  for (const auto& j : joints) expected += j.type == JointType::kSpherical ? 4 : 1;
  std::vector<double> durations;
  std::vector<Pose> frames;
  for (size_t f = 0; f < raw.size(); ++f) {
    std::string where = "frame " + std::to_string(f);
    const json& values = raw[f];
    if (!values.is_array() || values.size() != expected) {
      ThrowConfigError(
          origin, where + ": expected " + std::to_string(expected) + " values per frame, got " +
                      (values.is_array() ? std::to_string(values.size()) : values.dump()));
    }
    size_t k = 0;
    auto next = [&](const std::string& field) {
      double x = Number(values[k], origin, where + ": " + field);
      ++k;
      return x;
    };
    durations.push_back(next("duration"));
    Pose pose;
    Vec3 p;
    for (double& c : p) c = next("root position");
    pose.root_position = FromYUp(p);
    Quat q;
    for (double& c : q) c = next("root rotation");
    pose.root_rotation = FromYUp(q);
    for (const auto& joint : joints) {
      if (joint.type == JointType::kSpherical) {
        for (double& c : q) c = next(joint.name);
        pose.joint_rotations.push_back(FromYUp(q));
      } else {
        // A revolute joint turns about DeepMimic's +z, which is -y here.
        pose.joint_rotations.push_back(AxisAngle({0, -1, 0}, next(joint.name)));
      }
    }
    frames.push_back(std::move(pose));
  }
  // DeepMimic loops a clip by translating its root only (KinCharacter's cycle root delta).
  return Build(origin, std::filesystem::path(origin).stem().string(), loop, std::move(durations),
               std::move(frames), CycleTransform::kTranslation);
}

// The top-level fields are known ones, and the format and version this build reads.
void CheckProjectHeader(const json& doc, const std::string& origin) {
  static const std::set<std::string> kKeys = {"format",         "version", "name",
                                              "description",    "loop",    "cycle",
                                              "frame_duration", "joints",  "frames"};
  for (const auto& item : doc.items()) {
    if (!kKeys.count(item.key())) ThrowConfigError(origin, "unknown field '" + item.key() + "'");
  }
  if (!doc.contains("format") || !doc["format"].is_string() || doc["format"] != kFormatName) {
    ThrowConfigError(origin, std::string("format: expected \"") + kFormatName + "\"");
  }
  if (!doc.contains("version") || doc["version"] != kFormatVersion) {
    ThrowConfigError(origin, "version: this build reads version " + std::to_string(kFormatVersion));
  }
}

CycleTransform ReadCycle(const json& doc, const std::string& origin) {
  CycleTransform cycle = CycleTransform::kPlanar;
  if (doc.contains("cycle")) {
    const json& c = doc["cycle"];
    if (c != "planar" && c != "translation") {
      ThrowConfigError(origin, "cycle: expected \"planar\" or \"translation\", got " + c.dump());
    }
    if (c == "translation") cycle = CycleTransform::kTranslation;
  }
  return cycle;
}

// The joints this file animates, in the order of each frame's "rotations"; joints it leaves out
// stay at their rest (identity) rotation.
std::vector<int> ReadJointSlots(const json& doc, const std::string& origin) {
  const auto& skeleton = Humanoid3dJoints();
  if (!doc.contains("joints") || !doc["joints"].is_array()) {
    ThrowConfigError(origin, "joints: expected a list of joint names");
  }
  std::vector<int> slots;
  for (const auto& j : doc["joints"]) {
    if (!j.is_string()) ThrowConfigError(origin, "joints: expected names, got " + j.dump());
    int slot = FindJoint(j.get<std::string>());
    if (slot < 0) {
      std::string known;
      for (const auto& s : skeleton) known += " " + s.name;
      ThrowConfigError(origin, "joints: unknown joint '" + j.get<std::string>() +
                                   "'; the skeleton has:" + known);
    }
    for (int s : slots) {
      if (s == slot)
        ThrowConfigError(origin, "joints: '" + j.get<std::string>() + "' is listed twice");
    }
    slots.push_back(slot);
  }
  return slots;
}

// One entry of "frames" (`where` names it in errors); `slots` from ReadJointSlots.
Pose ReadProjectFrame(const json& frame, const std::string& where, const std::vector<int>& slots,
                      const std::string& origin) {
  const auto& skeleton = Humanoid3dJoints();
  if (!frame.is_object()) ThrowConfigError(origin, where + ": expected an object");
  for (const auto& item : frame.items()) {
    if (item.key() != "root_position" && item.key() != "root_rotation" &&
        item.key() != "rotations") {
      ThrowConfigError(origin, where + ": unknown field '" + item.key() + "'");
    }
  }
  Pose pose;
  pose.root_position =
      Numbers<3>(frame.value("root_position", json()), origin, where + ": root_position");
  pose.root_rotation =
      Numbers<4>(frame.value("root_rotation", json()), origin, where + ": root_rotation");
  pose.joint_rotations.assign(skeleton.size(), kIdentityQuat);
  const json& rotations = frame.value("rotations", json());
  if (!rotations.is_array() || rotations.size() != slots.size()) {
    ThrowConfigError(origin,
                     where + ": rotations: expected " + std::to_string(slots.size()) +
                         " quaternions (one per entry of \"joints\"), got " +
                         (rotations.is_array() ? std::to_string(rotations.size()) : "none"));
  }
  for (size_t j = 0; j < slots.size(); ++j) {
    pose.joint_rotations[slots[j]] =
        Numbers<4>(rotations[j], origin, where + ": rotations: " + skeleton[slots[j]].name);
  }
  return pose;
}

MotionClip ParseProjectClip(const json& doc, const std::string& origin) {
  CheckProjectHeader(doc, origin);
  std::string name =
      doc.contains("name") && doc["name"].is_string() ? doc["name"].get<std::string>() : origin;
  if (!doc.contains("loop") || !doc["loop"].is_boolean())
    ThrowConfigError(origin, "loop: expected true/false");
  bool loop = doc["loop"].get<bool>();
  CycleTransform cycle = ReadCycle(doc, origin);
  if (!doc.contains("frame_duration")) ThrowConfigError(origin, "frame_duration: missing");
  double frame_duration = Number(doc["frame_duration"], origin, "frame_duration");
  if (frame_duration <= 0) ThrowConfigError(origin, "frame_duration: must be positive");

  const std::vector<int> slots = ReadJointSlots(doc, origin);
  if (!doc.contains("frames") || !doc["frames"].is_array()) {
    ThrowConfigError(origin, "frames: expected a list of frames");
  }
  std::vector<Pose> frames;
  for (size_t f = 0; f < doc["frames"].size(); ++f) {
    const json& frame = doc["frames"][f];
    std::string where = "frame " + std::to_string(f);
    frames.push_back(ReadProjectFrame(frame, where, slots, origin));
  }
  std::vector<double> durations(frames.size(), frame_duration);
  return Build(origin, name, loop, std::move(durations), std::move(frames), cycle);
}

std::string Fixed(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6f", x == 0 ? 0.0 : x);  // no "-0.000000"
  return buffer;
}

template <size_t N>
std::string List(const std::array<double, N>& values) {
  std::string out = "[";
  for (size_t i = 0; i < N; ++i) out += (i ? ", " : "") + Fixed(values[i]);
  return out + "]";
}

}  // namespace

Vec3 FromYUp(const Vec3& v) { return {v[0], -v[2], v[1]}; }
Quat FromYUp(const Quat& q) { return {q[0], q[1], -q[3], q[2]}; }

MotionClip ParseMotion(const std::string& text, const std::string& origin) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::exception& e) {  // syntax, and numbers out of range (1e999)
    ThrowConfigError(origin, std::string("not valid JSON: ") + e.what());
  }
  if (!doc.is_object()) ThrowConfigError(origin, "expected a JSON object");
  if (doc.contains("Frames")) return ParseDeepMimic(doc, origin);
  return ParseProjectClip(doc, origin);
}

MotionClip LoadMotion(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open motion file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ParseMotion(buffer.str(), path);
}

std::string FormatClip(const MotionClip& clip, const std::string& description) {
  // Hand-written rather than json::dump so that every frame sits on one line: the files are
  // meant to be read and diffed by people.
  double frame_duration = clip.frame_duration(0);
  for (int i = 0; i + 1 < clip.num_frames(); ++i) {
    if (std::abs(clip.frame_duration(i) - frame_duration) > 1e-9) {
      throw std::invalid_argument("clip " + clip.name() +
                                  ": the project format needs evenly spaced frames");
    }
  }
  const auto& joints = Humanoid3dJoints();
  std::ostringstream out;
  out << "{\n  \"format\": \"" << kFormatName << "\",\n  \"version\": " << kFormatVersion
      << ",\n  \"name\": " << json(clip.name()).dump()
      << ",\n  \"description\": " << json(description).dump()
      << ",\n  \"loop\": " << (clip.loop() ? "true" : "false");
  // Written only where it is not the default: files of planar loops stay as they were.
  if (clip.loop() && clip.cycle_transform() == CycleTransform::kTranslation) {
    out << ",\n  \"cycle\": \"translation\"";
  }
  out << ",\n  \"frame_duration\": " << std::setprecision(17) << frame_duration
      << ",\n  \"joints\": [";
  for (size_t j = 0; j < joints.size(); ++j)
    out << (j ? ", " : "") << "\"" << joints[j].name << "\"";
  out << "],\n  \"frames\": [\n";
  for (int f = 0; f < clip.num_frames(); ++f) {
    const Pose& pose = clip.frame(f);
    out << "    {\"root_position\": " << List(pose.root_position)
        << ", \"root_rotation\": " << List(pose.root_rotation) << ", \"rotations\": [";
    for (size_t j = 0; j < pose.joint_rotations.size(); ++j) {
      out << (j ? ", " : "") << List(pose.joint_rotations[j]);
    }
    out << "]}" << (f + 1 < clip.num_frames() ? "," : "") << "\n";
  }
  out << "  ]\n}\n";
  return out.str();
}

void SaveClip(const MotionClip& clip, const std::string& description, const std::string& path) {
  std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw ConfigError(path + ": cannot write");
    out << FormatClip(clip, description);
    if (!out.flush()) throw ConfigError(path + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw ConfigError(path + ": rename failed");
}

}  // namespace ragdoll::character
