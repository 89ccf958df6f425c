#include "actor/sim/foot_cleanup.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "actor/sim/leg_ik.h"
#include "actor/sim/skeleton.h"

namespace ragdoll::sim {
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

// The corners of the foot's box geoms in the ankle body's frame.
std::vector<Vec3> FootCorners(const mjModel* m, int body) {
  std::vector<Vec3> corners;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] != body || m->geom_type[g] != mjGEOM_BOX) continue;
    double mat[9];
    mju_quat2Mat(mat, m->geom_quat + 4 * g);
    const double* size = m->geom_size + 3 * g;
    for (int c = 0; c < 8; ++c) {
      const double local[3] = {(c & 1 ? 1 : -1) * size[0], (c & 2 ? 1 : -1) * size[1],
                               (c & 4 ? 1 : -1) * size[2]};
      Vec3 corner;
      for (int i = 0; i < 3; ++i) {
        corner[i] = m->geom_pos[3 * g + i] + mat[3 * i] * local[0] + mat[3 * i + 1] * local[1] +
                    mat[3 * i + 2] * local[2];
      }
      corners.push_back(corner);
    }
  }
  return corners;
}

// Smooth 0 -> 1 over x in [0, 1] (zero slope at both ends: the fade has no kink).
double SmoothStep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

struct Plant {
  int first = 0, last = 0;  // frames, inclusive
};

}  // namespace

MotionClip FixFeet(const MotionClip& clip, const Character& character,
                   const FootCleanupOptions& options, FootCleanupReport* report) {
  if (!(options.plant_height > 0 && options.plant_speed > 0 && options.min_plant > 0 &&
        options.blend > 0)) {
    throw std::invalid_argument("foot clean-up: every threshold must be positive");
  }
  const mjModel* m = character.model();
  DataPtr d = character.MakeData();
  DataPtr scratch = character.MakeData();
  const int n = clip.num_frames();

  // Each foot in every frame: the ankle's pose, the foot's lowest point, the hip joint.
  int ankle_body[2], hip_body[2];
  double reach[2];  // hip to ankle with the knee straight, m
  std::vector<int> foot_geoms[2];
  std::vector<Vec3> corners[2];
  std::vector<Vec3> position[2], hip[2];
  std::vector<Quat> rotation[2];
  std::vector<double> lowest[2];
  for (int s = 0; s < 2; ++s) {
    const std::string side = kSides[s];
    ankle_body[s] = character.BodyId(side + "_ankle");
    hip_body[s] = character.BodyId(side + "_hip");
    reach[s] = mju_norm3(m->body_pos + 3 * character.BodyId(side + "_knee")) +
               mju_norm3(m->body_pos + 3 * ankle_body[s]);
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] == ankle_body[s]) foot_geoms[s].push_back(g);
    }
    corners[s] = FootCorners(m, ankle_body[s]);
    if (corners[s].empty()) {
      throw std::invalid_argument("foot clean-up: the character's " + side +
                                  "_ankle body has no box geom (the sole)");
    }
    position[s].resize(n);
    hip[s].resize(n);
    rotation[s].resize(n);
    lowest[s].resize(n);
  }
  for (int f = 0; f < n; ++f) {
    character.PoseToQpos(clip.frame(f), d->qpos);
    mj_kinematics(m, d.get());
    for (int s = 0; s < 2; ++s) {
      for (int k = 0; k < 3; ++k) position[s][f][k] = d->xpos[3 * ankle_body[s] + k];
      for (int k = 0; k < 3; ++k) hip[s][f][k] = d->xpos[3 * hip_body[s] + k];
      for (int k = 0; k < 4; ++k) rotation[s][f][k] = d->xquat[4 * ankle_body[s] + k];
      lowest[s][f] = INFINITY;
      for (int g : foot_geoms[s])
        lowest[s][f] = std::min(lowest[s][f], GeomLowestPoint(m, d.get(), g));
    }
  }

  // Plants: runs of frames where a foot is low (against its own lowest height) and slow.
  FootCleanupReport r;
  std::vector<Plant> plants[2];
  // Speeds over a 0.1 s window: capture jitter from frame to frame is not motion.
  const double frame_dt = clip.duration() / std::max(n - 1, 1);
  const int span = std::max(1, static_cast<int>(std::lround(kSpeedWindow / 2 / frame_dt)));
  for (int s = 0; s < 2; ++s) {
    std::vector<double> heights = lowest[s];
    std::sort(heights.begin(), heights.end());
    const double low = heights[static_cast<size_t>(kLowQuantile * (n - 1))];
    r.float_height[s] = low;
    std::vector<char> planted(n, 0);
    for (int f = 0; f < n; ++f) {
      const int a = std::max(f - span, 0), b = std::min(f + span, n - 1);
      const double dt = clip.frame_time(b) - clip.frame_time(a);
      const double speed =
          std::hypot(position[s][b][0] - position[s][a][0], position[s][b][1] - position[s][a][1]) /
          dt;
      planted[f] = lowest[s][f] < low + options.plant_height && speed < options.plant_speed;
    }
    for (int f = 0; f < n;) {
      if (!planted[f]) {
        ++f;
        continue;
      }
      Plant p;
      p.first = f;
      while (f + 1 < n && planted[f + 1]) ++f;
      p.last = f++;
      if (clip.frame_time(p.last) - clip.frame_time(p.first) < options.min_plant) continue;
      plants[s].push_back(p);
      r.planted_fraction[s] += static_cast<double>(p.last - p.first + 1) / n;
    }
    r.plants[s] = static_cast<int>(plants[s].size());
  }

  // Where each ankle should be. In a plant the foot keeps its rotation and rolls on the floor:
  // its lowest corner is on the floor and, while it stays the lowest, still. Around a plant the
  // plant's first or last correction fades in or out.
  std::vector<Vec3> target[2];
  std::vector<char> moved[2];
  std::vector<double> drop(n, 0.0);  // how far the pelvis must come down for a leg to reach
  for (int s = 0; s < 2; ++s) {
    target[s] = position[s];
    moved[s].assign(n, 0);
    std::vector<Vec3> correction(n, Vec3{0, 0, 0});
    for (const Plant& p : plants[s]) {
      int contact = -1;
      double anchor[2] = {0, 0};
      for (int k = p.first; k <= p.last; ++k) {
        int c = 0;
        std::vector<Vec3> offsets(corners[s].size());
        for (size_t i = 0; i < offsets.size(); ++i) {
          offsets[i] = Rotate(rotation[s][k], corners[s][i]);
          if (offsets[i][2] < offsets[c][2]) c = static_cast<int>(i);
        }
        if (contact < 0) {
          for (int i = 0; i < 2; ++i) anchor[i] = position[s][k][i] + offsets[c][i];
        } else if (c != contact) {  // the foot rolls onto another corner where the ankle is
          for (int i = 0; i < 2; ++i) anchor[i] = target[s][k - 1][i] + offsets[c][i];
        }
        contact = c;
        target[s][k] = {anchor[0] - offsets[c][0], anchor[1] - offsets[c][1], -offsets[c][2]};
        for (int i = 0; i < 3; ++i) correction[k][i] = target[s][k][i] - position[s][k][i];
        moved[s][k] = 1;
      }
    }
    for (int f = 0; f < n; ++f) {
      if (moved[s][f]) continue;
      const double t = clip.frame_time(f);
      int from = -1;
      double weight = 0;
      for (const Plant& p : plants[s]) {
        const int edge = t < clip.frame_time(p.first) ? p.first : p.last;
        const double w = SmoothStep(1 - std::abs(t - clip.frame_time(edge)) / options.blend);
        if (w > weight) {
          weight = w;
          from = edge;
        }
      }
      if (from < 0) continue;
      for (int i = 0; i < 3; ++i) target[s][f][i] += weight * correction[from][i];
      // A foot outside its plant moves: it is kept clear of the floor (unless it was lower).
      const double was = lowest[s][f], now = was + weight * correction[from][2];
      if (now < kClearance && now < was) target[s][f][2] += std::min(was, kClearance) - now;
      moved[s][f] = 1;
    }
    for (int f = 0; f < n; ++f) {
      if (!moved[s][f]) continue;
      const Vec3& was = position[s][f];
      r.max_correction = std::max(
          r.max_correction,
          std::hypot(target[s][f][0] - was[0], target[s][f][1] - was[1], target[s][f][2] - was[2]));
      // The pelvis comes down when the hip is farther from the target than the leg reaches.
      const double h = std::hypot(target[s][f][0] - hip[s][f][0], target[s][f][1] - hip[s][f][1]);
      const double v = hip[s][f][2] - target[s][f][2];
      // (A leg the clip itself stretches that far may stay so: the knee was straight there.)
      const double r2 =
          std::max(kReachFraction * reach[s],
                   std::hypot(position[s][f][0] - hip[s][f][0], position[s][f][1] - hip[s][f][1],
                              position[s][f][2] - hip[s][f][2]));
      if (h < r2) drop[f] = std::max(drop[f], v - std::sqrt(r2 * r2 - h * h));
    }
  }
  // The drop, smoothed: a running maximum, then a running mean half as wide, so that every
  // frame still comes down at least as far as it needs.
  const int half = std::max(1, static_cast<int>(std::lround(options.blend / frame_dt)));
  std::vector<double> widest(n, 0.0), smooth(n, 0.0);
  for (int f = 0; f < n; ++f) {
    for (int k = std::max(0, f - half); k <= std::min(n - 1, f + half); ++k) {
      widest[f] = std::max(widest[f], drop[k]);
    }
  }
  for (int f = 0; f < n; ++f) {
    const int a = std::max(0, f - half / 2), b = std::min(n - 1, f + half / 2);
    for (int k = a; k <= b; ++k) smooth[f] += widest[k] / (b - a + 1);
    r.max_drop = std::max(r.max_drop, smooth[f]);
  }

  // Each frame: the pelvis lowered, every leg whose foot moves (or whose hip did) re-solved.
  std::vector<Pose> frames;
  frames.reserve(n);
  std::vector<double> qpos(m->nq);
  for (int f = 0; f < n; ++f) {
    Pose pose = clip.frame(f);
    pose.root_position[2] -= smooth[f];
    character.PoseToQpos(pose, qpos.data());
    bool missed = false;
    for (int s = 0; s < 2; ++s) {
      if (!moved[s][f] && smooth[f] == 0) continue;
      const LegIkResult ik = SolveLegIk(character, kSides[s], target[s][f], rotation[s][f],
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

}  // namespace ragdoll::sim
