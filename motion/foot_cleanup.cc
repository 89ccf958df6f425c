#include "motion/foot_cleanup.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "character/skeleton.h"
#include "motion/foot_geometry.h"
#include "motion/leg_ik.h"

namespace ragdoll::motion {

using character::Character;
using character::DataPtr;
using character::FindJoint;
using character::GeomLowestPoint;
using character::MotionClip;
using character::Pose;
using character::Quat;
using character::Rotate;
using character::Vec3;

namespace {

constexpr const char* kSides[2] = {"right", "left"};
// A leg is taken to reach this fraction of its straight length: a straight knee is singular.
constexpr double kReachFraction = 0.995;
// Foot speeds are measured across this window, s.
constexpr double kSpeedWindow = 0.1;
// A foot outside its plant, lowered toward it, stays this far above the floor: it is moving.
constexpr double kClearance = 0.01;  // m
// A solved ankle farther than this from its target counts as a miss.
constexpr double kMissTolerance = 0.01;  // m
// The lowest ankle height of a foot ignores this fraction of its lowest frames (glitches).
constexpr double kLowQuantile = 0.01;

// Smooth 0 -> 1 over x in [0, 1] (zero slope at both ends: the fade has no kink).
double SmoothStep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

struct Plant {
  int first = 0, last = 0;  // frames, inclusive
};

// One foot through the clip, by forward kinematics of every frame.
struct FootTrack {
  std::vector<Vec3> ankle, hip;  // joint positions, world
  std::vector<Quat> rotation;    // the foot's (ankle body's) world rotation
  std::vector<double> lowest;    // the foot's lowest point, m
  std::vector<Vec3> corners;     // the sole's corners in the foot's frame
  double reach = 0;              // hip to ankle with the knee straight, m
};

std::array<FootTrack, 2> TrackFeet(const MotionClip& clip, const Character& character) {
  const mjModel* m = character.model();
  DataPtr d = character.MakeData();
  const int n = clip.num_frames();
  std::array<FootTrack, 2> feet;
  int ankle_body[2], hip_body[2];
  std::vector<int> geoms[2];
  for (int s = 0; s < 2; ++s) {
    const std::string side = kSides[s];
    ankle_body[s] = character.BodyId(side + "_ankle");
    hip_body[s] = character.BodyId(side + "_hip");
    FootTrack& foot = feet[s];
    foot.reach = mju_norm3(m->body_pos + 3 * character.BodyId(side + "_knee")) +
                 mju_norm3(m->body_pos + 3 * ankle_body[s]);
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] == ankle_body[s]) geoms[s].push_back(g);
    }
    foot.corners = FootCorners(m, ankle_body[s]);
    if (foot.corners.empty()) {
      throw std::invalid_argument("foot clean-up: the character's " + side +
                                  "_ankle body has no box geom (the sole)");
    }
    foot.ankle.resize(n);
    foot.hip.resize(n);
    foot.rotation.resize(n);
    foot.lowest.assign(n, INFINITY);
  }
  for (int f = 0; f < n; ++f) {
    character.PoseToQpos(clip.frame(f), d->qpos);
    mj_kinematics(m, d.get());
    for (int s = 0; s < 2; ++s) {
      FootTrack& foot = feet[s];
      for (int k = 0; k < 3; ++k) foot.ankle[f][k] = d->xpos[3 * ankle_body[s] + k];
      for (int k = 0; k < 3; ++k) foot.hip[f][k] = d->xpos[3 * hip_body[s] + k];
      for (int k = 0; k < 4; ++k) foot.rotation[f][k] = d->xquat[4 * ankle_body[s] + k];
      for (int g : geoms[s])
        foot.lowest[f] = std::min(foot.lowest[f], GeomLowestPoint(m, d.get(), g));
    }
  }
  return feet;
}

// Runs of frames where the foot is low (against its own lowest height, `*low`) and slow.
std::vector<Plant> FindPlants(const MotionClip& clip, const FootTrack& foot,
                              const FootCleanupOptions& options, double* low) {
  const int n = clip.num_frames();
  std::vector<double> heights = foot.lowest;
  std::sort(heights.begin(), heights.end());
  *low = heights[static_cast<size_t>(kLowQuantile * (n - 1))];
  // Speeds over a window: capture jitter from frame to frame is not motion.
  const double frame_dt = clip.duration() / std::max(n - 1, 1);
  const int span = std::max(1, static_cast<int>(std::lround(kSpeedWindow / 2 / frame_dt)));
  std::vector<char> planted(n, 0);
  for (int f = 0; f < n; ++f) {
    const int a = std::max(f - span, 0), b = std::min(f + span, n - 1);
    const double speed =
        std::hypot(foot.ankle[b][0] - foot.ankle[a][0], foot.ankle[b][1] - foot.ankle[a][1]) /
        (clip.frame_time(b) - clip.frame_time(a));
    planted[f] = foot.lowest[f] < *low + options.plant_height && speed < options.plant_speed;
  }
  std::vector<Plant> plants;
  for (int f = 0; f < n;) {
    if (!planted[f]) {
      ++f;
      continue;
    }
    Plant p;
    p.first = f;
    while (f + 1 < n && planted[f + 1]) ++f;
    p.last = f++;
    if (clip.frame_time(p.last) - clip.frame_time(p.first) >= options.min_plant)
      plants.push_back(p);
  }
  return plants;
}

// Where the ankle should be in each frame (`moved`: whether that differs from the clip). In a
// plant the foot keeps its rotation and rolls on the floor: its lowest corner is on the floor
// and, while it stays the lowest, still. Around a plant the plant's first or last correction
// fades in or out, and a foot lowered toward it is kept clear of the floor.
std::vector<Vec3> AnkleTargets(const MotionClip& clip, const FootTrack& foot,
                               const std::vector<Plant>& plants, double blend,
                               std::vector<char>* moved) {
  const int n = clip.num_frames();
  std::vector<Vec3> target = foot.ankle;
  std::vector<Vec3> correction(n, Vec3{0, 0, 0});
  moved->assign(n, 0);
  std::vector<Vec3> offsets(foot.corners.size());  // the sole's corners from the ankle, world
  for (const Plant& p : plants) {
    int contact = -1;
    double anchor[2] = {0, 0};
    for (int k = p.first; k <= p.last; ++k) {
      int c = 0;
      for (size_t i = 0; i < offsets.size(); ++i) {
        offsets[i] = Rotate(foot.rotation[k], foot.corners[i]);
        if (offsets[i][2] < offsets[c][2]) c = static_cast<int>(i);
      }
      if (contact < 0) {
        for (int i = 0; i < 2; ++i) anchor[i] = foot.ankle[k][i] + offsets[c][i];
      } else if (c != contact) {  // the foot rolls onto another corner where the ankle is
        for (int i = 0; i < 2; ++i) anchor[i] = target[k - 1][i] + offsets[c][i];
      }
      contact = c;
      target[k] = {anchor[0] - offsets[c][0], anchor[1] - offsets[c][1], -offsets[c][2]};
      for (int i = 0; i < 3; ++i) correction[k][i] = target[k][i] - foot.ankle[k][i];
      (*moved)[k] = 1;
    }
  }
  for (int f = 0; f < n; ++f) {
    if ((*moved)[f]) continue;
    const double t = clip.frame_time(f);
    int from = -1;
    double weight = 0;
    for (const Plant& p : plants) {
      const int edge = t < clip.frame_time(p.first) ? p.first : p.last;
      const double w = SmoothStep(1 - std::abs(t - clip.frame_time(edge)) / blend);
      if (w > weight) {
        weight = w;
        from = edge;
      }
    }
    if (from < 0) continue;
    for (int i = 0; i < 3; ++i) target[f][i] += weight * correction[from][i];
    // A foot outside its plant moves: it is kept clear of the floor (unless it was lower).
    const double was = foot.lowest[f], now = was + weight * correction[from][2];
    if (now < kClearance && now < was) target[f][2] += std::min(was, kClearance) - now;
    (*moved)[f] = 1;
  }
  return target;
}

// How far the pelvis must come down for the hip to reach `target`: a leg reaches a little short
// of straight, or as far as the clip itself stretches it (the knee was straight there).
double RequiredDrop(const FootTrack& foot, int f, const Vec3& target) {
  const Vec3& hip = foot.hip[f];
  const double h = std::hypot(target[0] - hip[0], target[1] - hip[1]);
  const double v = hip[2] - target[2];
  const double reach = std::max(
      kReachFraction * foot.reach,
      std::hypot(foot.ankle[f][0] - hip[0], foot.ankle[f][1] - hip[1], foot.ankle[f][2] - hip[2]));
  return h < reach ? std::max(0.0, v - std::sqrt(reach * reach - h * h)) : 0.0;
}

// A running maximum over +-`half` frames, then a running mean half as wide: smooth, and every
// frame still at least its own value.
std::vector<double> SmoothUpper(const std::vector<double>& x, int half) {
  const int n = static_cast<int>(x.size());
  std::vector<double> widest(n, 0.0), smooth(n, 0.0);
  for (int f = 0; f < n; ++f) {
    for (int k = std::max(0, f - half); k <= std::min(n - 1, f + half); ++k) {
      widest[f] = std::max(widest[f], x[k]);
    }
  }
  for (int f = 0; f < n; ++f) {
    const int a = std::max(0, f - half / 2), b = std::min(n - 1, f + half / 2);
    for (int k = a; k <= b; ++k) smooth[f] += widest[k] / (b - a + 1);
  }
  return smooth;
}

}  // namespace

MotionClip FixFeet(const MotionClip& clip, const Character& character,
                   const FootCleanupOptions& options, FootCleanupReport* report) {
  if (!(options.plant_height > 0 && options.plant_speed > 0 && options.min_plant > 0 &&
        options.blend > 0)) {
    throw std::invalid_argument("foot clean-up: every threshold must be positive");
  }
  const int n = clip.num_frames();
  const std::array<FootTrack, 2> feet = TrackFeet(clip, character);
  FootCleanupReport r;
  std::vector<Vec3> target[2];
  std::vector<char> moved[2];
  std::vector<double> drop(n, 0.0);
  for (int s = 0; s < 2; ++s) {
    const std::vector<Plant> plants = FindPlants(clip, feet[s], options, &r.float_height[s]);
    r.plants[s] = static_cast<int>(plants.size());
    for (const Plant& p : plants)
      r.planted_fraction[s] += static_cast<double>(p.last - p.first + 1) / n;
    target[s] = AnkleTargets(clip, feet[s], plants, options.blend, &moved[s]);
    for (int f = 0; f < n; ++f) {
      if (!moved[s][f]) continue;
      const Vec3& was = feet[s].ankle[f];
      r.max_correction = std::max(
          r.max_correction,
          std::hypot(target[s][f][0] - was[0], target[s][f][1] - was[1], target[s][f][2] - was[2]));
      drop[f] = std::max(drop[f], RequiredDrop(feet[s], f, target[s][f]));
    }
  }
  const double frame_dt = clip.duration() / std::max(n - 1, 1);
  const std::vector<double> lower =
      SmoothUpper(drop, std::max(1, static_cast<int>(std::lround(options.blend / frame_dt))));
  for (double x : lower) r.max_drop = std::max(r.max_drop, x);

  // Each frame: the pelvis lowered, every leg whose foot moves (or whose hip did) re-solved.
  DataPtr scratch = character.MakeData();
  std::vector<Pose> frames;
  frames.reserve(n);
  std::vector<double> qpos(character.model()->nq);
  for (int f = 0; f < n; ++f) {
    Pose pose = clip.frame(f);
    pose.root_position[2] -= lower[f];
    character.PoseToQpos(pose, qpos.data());
    bool missed = false;
    for (int s = 0; s < 2; ++s) {
      if (!moved[s][f] && lower[f] == 0) continue;
      const LegIkResult ik = SolveLegIk(character, kSides[s], target[s][f], feet[s].rotation[f],
                                        qpos.data(), scratch.get());
      r.max_miss = std::max(r.max_miss, ik.position_error);
      missed |= ik.position_error > kMissTolerance;
      // Only the solved leg's joints change; the rest of the pose keeps its exact rotations.
      for (const char* part : {"_hip", "_knee", "_ankle"}) {
        const int j = FindJoint(std::string(kSides[s]) + part);
        pose.joint_rotations[j] = character.JointRotation(qpos.data(), j);
      }
    }
    r.missed_frames += missed;
    frames.push_back(std::move(pose));
  }
  std::vector<double> durations(n);
  for (int f = 0; f < n; ++f) durations[f] = clip.frame_duration(f);
  if (report != nullptr) *report = r;
  return MotionClip(clip.name(), clip.loop(), std::move(durations), std::move(frames),
                    clip.cycle_transform());
}

}  // namespace ragdoll::motion
