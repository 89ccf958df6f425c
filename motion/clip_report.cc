#include "motion/clip_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "character/ground_contacts.h"
#include "character/skeleton.h"

namespace ragdoll::motion {

using character::Character;
using character::DataPtr;
using character::DecomposeHinges;
using character::GeomLowestPoint;
using character::Humanoid3dJoints;
using character::MotionClip;
using character::Pose;
using character::Vec3;

namespace {

constexpr double kPenetration = 0.01;     // m below the floor
constexpr double kSlidingSpeed = 0.3;     // m/s of a planted foot's lowest point
constexpr double kPlanted = 0.005;        // m: a corner this close to the floor bears weight
constexpr double kLimitTolerance = 0.05;  // rad beyond a hinge's range

// The 8 corners of a box geom in world coordinates.
std::array<Vec3, 8> BoxCorners(const mjModel* m, const mjData* d, int g) {
  const double* p = d->geom_xpos + 3 * g;
  const double* r = d->geom_xmat + 9 * g;
  const double* s = m->geom_size + 3 * g;
  std::array<Vec3, 8> corners;
  for (int c = 0; c < 8; ++c) {
    const double local[3] = {(c & 1 ? 1 : -1) * s[0], (c & 2 ? 1 : -1) * s[1],
                             (c & 4 ? 1 : -1) * s[2]};
    for (int i = 0; i < 3; ++i) {
      corners[c][i] =
          p[i] + r[3 * i] * local[0] + r[3 * i + 1] * local[1] + r[3 * i + 2] * local[2];
    }
  }
  return corners;
}

// The clip's own figures: its timing, joints, root travel and cycle, with the extremes that the
// frame loop narrows down set to start.
ClipReport ClipFigures(const MotionClip& clip) {
  ClipReport r;
  r.name = clip.name();
  r.frames = clip.num_frames();
  r.duration = clip.duration();
  r.fps = r.frames > 1 ? (r.frames - 1) / r.duration : 0;
  r.loop = clip.loop();
  for (const auto& j : Humanoid3dJoints()) r.joints.push_back(j.name);
  r.root_travel = {clip.frame(r.frames - 1).root_position[0] - clip.frame(0).root_position[0],
                   clip.frame(r.frames - 1).root_position[1] - clip.frame(0).root_position[1],
                   clip.frame(r.frames - 1).root_position[2] - clip.frame(0).root_position[2]};
  r.cycle_displacement = clip.cycle_displacement();
  r.cycle_yaw = clip.cycle_yaw();
  r.root_height_min = INFINITY;
  r.root_height_max = -INFINITY;
  r.lowest_point = INFINITY;
  return r;
}

// Feet: the box geoms of each ankle body.
std::map<std::string, std::vector<int>> FootGeoms(const mjModel* m, const Character& character) {
  std::map<std::string, std::vector<int>> feet;
  for (const char* side : {"right_ankle", "left_ankle"}) {
    int body = character.BodyId(side);
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] == body && m->geom_type[g] == mjGEOM_BOX) feet[side].push_back(g);
    }
  }
  return feet;
}

// Joint limits: the pose's rotations on the hinges, before the character would clamp them.
void CheckJointLimits(const Character& character, const Pose& pose, int f, double t,
                      ClipReport& r) {
  std::vector<double> q(3);
  const auto& joints = character.joints();
  for (size_t j = 0; j < joints.size(); ++j) {
    DecomposeHinges(joints[j].axes, pose.joint_rotations[j], q.data());
    for (const auto& h : character.hinges()) {
      if (h.joint != static_cast<int>(j)) continue;
      const double angle = q[h.qpos_address - joints[j].qpos_address];
      const double beyond = std::max(h.lower - angle, angle - h.upper);
      if (beyond > kLimitTolerance) {
        char detail[160];
        std::snprintf(detail, sizeof(detail), "%s %.2f rad, range [%.2f, %.2f]", h.name.c_str(),
                      angle, h.lower, h.upper);
        r.issues.push_back({f, t, "joint_limit", detail});
      }
    }
  }
}

// The body geometry's lowest point in this frame's kinematics, and whether it is under the floor.
void CheckPenetration(const mjModel* m, const mjData* d, int f, double t, ClipReport& r) {
  double lowest = INFINITY;
  int lowest_body = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] == 0) continue;
    double z = GeomLowestPoint(m, d, g);
    if (z < lowest) {
      lowest = z;
      lowest_body = m->geom_bodyid[g];
    }
  }
  r.lowest_point = std::min(r.lowest_point, lowest);
  if (lowest < -kPenetration) {
    char detail[160];
    std::snprintf(detail, sizeof(detail), "%s %.1f cm below the floor",
                  mj_id2name(m, mjOBJ_BODY, lowest_body), -lowest * 100);
    r.issues.push_back({f, t, "penetration", detail});
  }
}

// A foot's lowest corner over its box geoms: its height, its index (-1 for no corner) and all
// the corners of its box.
double LowestCorner(const mjModel* m, const mjData* d, const std::vector<int>& geoms,
                    std::array<Vec3, 8>* corners, int* lowest_corner) {
  double foot_lowest = INFINITY;
  for (int g : geoms) {
    auto c = BoxCorners(m, d, g);
    for (int i = 0; i < 8; ++i) {
      if (c[i][2] < foot_lowest) {
        foot_lowest = c[i][2];
        *lowest_corner = i;
        *corners = c;
      }
    }
  }
  return foot_lowest;
}

// The feet over the frames: how many frames each touches the floor in.
struct FeetState {
  std::map<std::string, int> contact_frames;
  // Per foot: the previous frame's corners and which corner was lowest, if it was in contact.
  std::map<std::string, std::array<Vec3, 8>> previous_corners;
  std::map<std::string, int> previous_lowest;
};

// One foot in frame f: counts its contact, and whether a planted corner slides.
void CheckFoot(const MotionClip& clip, const mjModel* m, const mjData* d, int f, double t,
               const std::string& side, const std::vector<int>& geoms, FeetState& state,
               ClipReport& r) {
  std::map<std::string, int>& contact_frames = state.contact_frames;
  std::map<std::string, std::array<Vec3, 8>>& previous_corners = state.previous_corners;
  std::map<std::string, int>& previous_lowest = state.previous_lowest;
  std::array<Vec3, 8> corners{};
  int lowest_corner = -1;
  const double foot_lowest = LowestCorner(m, d, geoms, &corners, &lowest_corner);
  const bool contact = foot_lowest < character::kGroundContactHeight;
  if (contact) ++contact_frames[side];
  if (contact && previous_lowest.count(side) && f > 0) {
    // The corner that was lowest (planted) last frame: how fast did it move?
    const Vec3& before = previous_corners[side][previous_lowest[side]];
    const Vec3& now = corners[previous_lowest[side]];
    const double dt = clip.frame_time(f) - clip.frame_time(f - 1);
    const double speed = std::hypot(now[0] - before[0], now[1] - before[1]) / dt;
    // Only a corner on the floor in both frames is planted (not a heel or toe lifting off).
    if (before[2] < kPlanted && now[2] < kPlanted && speed > kSlidingSpeed) {
      char detail[160];
      std::snprintf(detail, sizeof(detail), "%s planted, slides at %.2f m/s", side.c_str(), speed);
      r.issues.push_back({f, t, "foot_sliding", detail});
    }
  }
  if (contact) {
    previous_corners[side] = corners;
    previous_lowest[side] = lowest_corner;
  } else {
    previous_lowest.erase(side);
  }
}

}  // namespace

int ClipReport::Count(const std::string& kind) const {
  return static_cast<int>(std::count_if(issues.begin(), issues.end(),
                                        [&](const ClipIssue& i) { return i.kind == kind; }));
}

ClipReport InspectClip(const MotionClip& clip, const Character& character) {
  const mjModel* m = character.model();
  DataPtr d = character.MakeData();
  ClipReport r = ClipFigures(clip);
  const std::map<std::string, std::vector<int>> feet = FootGeoms(m, character);
  FeetState feet_state;
  for (int f = 0; f < r.frames; ++f) {
    const Pose& pose = clip.frame(f);
    const double t = clip.frame_time(f);
    r.root_height_min = std::min(r.root_height_min, pose.root_position[2]);
    r.root_height_max = std::max(r.root_height_max, pose.root_position[2]);
    if (f > 0) {
      const Vec3& a = clip.frame(f - 1).root_position;
      r.root_path_length += std::hypot(pose.root_position[0] - a[0], pose.root_position[1] - a[1]);
    }
    CheckJointLimits(character, pose, f, t, r);
    character.PoseToQpos(pose, d->qpos);
    mj_kinematics(m, d.get());
    CheckPenetration(m, d.get(), f, t, r);
    for (const auto& [side, geoms] : feet) {
      CheckFoot(clip, m, d.get(), f, t, side, geoms, feet_state, r);
    }
  }
  std::map<std::string, int>& contact_frames = feet_state.contact_frames;
  r.contact_right = static_cast<double>(contact_frames["right_ankle"]) / r.frames;
  r.contact_left = static_cast<double>(contact_frames["left_ankle"]) / r.frames;
  r.ground_contacts = character::GroundContactFractions(clip, character);
  r.renormalized_rotations = clip.renormalized_rotations();
  r.max_norm_deviation = clip.max_norm_deviation();
  return r;
}

std::string ClipReport::ToText() const {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "clip            %s (%s)\n", name.c_str(),
                loop ? "looping" : "not looping");
  out << line;
  std::snprintf(line, sizeof(line), "duration        %.3f s, %d frames, %.1f frames/s\n", duration,
                frames, fps);
  out << line;
  out << "joints          " << joints.size() << ":";
  for (const auto& j : joints) out << " " << j;
  out << "\n";
  std::snprintf(line, sizeof(line),
                "root travel     %+.3f %+.3f %+.3f m (x forward, y left, z up); path %.3f m\n",
                root_travel[0], root_travel[1], root_travel[2], root_path_length);
  out << line;
  if (loop) {
    std::snprintf(line, sizeof(line), "per cycle       %+.3f %+.3f %+.3f m, turn %+.1f deg\n",
                  cycle_displacement[0], cycle_displacement[1], cycle_displacement[2],
                  cycle_yaw * 180 / M_PI);
    out << line;
  }
  std::snprintf(line, sizeof(line), "root height     %.3f .. %.3f m; lowest geometry %+.1f cm\n",
                root_height_min, root_height_max, lowest_point * 100);
  out << line;
  std::snprintf(line, sizeof(line), "foot contact    right %.0f %% of frames, left %.0f %%\n",
                contact_right * 100, contact_left * 100);
  out << line;
  out << "ground contact ";
  for (const auto& [body, fraction] : ground_contacts) {
    std::snprintf(line, sizeof(line), " %s %.0f %%", body.c_str(), fraction * 100);
    out << line;
  }
  out << (ground_contacts.empty() ? " none\n" : "\n");
  std::snprintf(line, sizeof(line),
                "rotations       %d renormalised (norm off by more than 0.001); largest "
                "|norm - 1| %.4f\n",
                renormalized_rotations, max_norm_deviation);
  out << line;
  for (const char* kind : {"penetration", "foot_sliding", "joint_limit"}) {
    const int n = Count(kind);
    std::snprintf(line, sizeof(line), "%-15s %d frame%s\n", kind, n, n == 1 ? "" : "s");
    out << line;
    int shown = 0;
    for (const auto& i : issues) {
      if (i.kind != kind || shown++ >= 5) continue;
      std::snprintf(line, sizeof(line), "  frame %d (%.3f s): %s\n", i.frame, i.time,
                    i.detail.c_str());
      out << line;
    }
    if (shown > 5) out << "  ... and " << shown - 5 << " more\n";
  }
  return out.str();
}

std::string ClipReport::ToJson() const {
  nlohmann::json j;
  j["name"] = name;
  j["frames"] = frames;
  j["duration"] = duration;
  j["fps"] = fps;
  j["loop"] = loop;
  j["joints"] = joints;
  j["root_travel"] = root_travel;
  j["root_path_length"] = root_path_length;
  j["cycle_displacement"] = cycle_displacement;
  j["cycle_yaw"] = cycle_yaw;
  j["root_height"] = {root_height_min, root_height_max};
  j["lowest_point"] = lowest_point;
  j["foot_contact"] = {{"right", contact_right}, {"left", contact_left}};
  nlohmann::json contacts = nlohmann::json::object();
  for (const auto& [body, fraction] : ground_contacts) contacts[body] = fraction;
  j["ground_contacts"] = contacts;
  j["renormalized_rotations"] = renormalized_rotations;
  j["max_norm_deviation"] = max_norm_deviation;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& i : issues) {
    list.push_back({{"frame", i.frame}, {"time", i.time}, {"kind", i.kind}, {"detail", i.detail}});
  }
  j["issues"] = list;
  return j.dump(2);
}

}  // namespace ragdoll::motion
