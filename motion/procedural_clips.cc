#include "motion/procedural_clips.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>

#include "motion/leg_ik.h"

namespace ragdoll::motion {

using character::AxisAngle;
using character::Character;
using character::DataPtr;
using character::MotionClip;
using character::Multiply;
using character::Pose;
using character::Quat;
using character::Vec3;

namespace {

// Key frames per second. The walk uses more: its legs move fast enough that interpolating
// joint rotations between 30 fps key frames lets a planted sole dip into the floor
// (docs/motion-import.md, "Authored clips").
constexpr double kFps = 30;
constexpr double kWalkFps = 60;

// Leg dimensions of humanoid3d (assets/character/humanoid.xml): hip to knee, knee to ankle, and
// ankle joint to sole.
constexpr double kThigh = 0.421546;
constexpr double kShank = 0.40987;
constexpr double kAnkleHeight = 0.05;

// Hinge angles of every joint for one frame, by hinge name, plus the root.
struct Frame {
  Vec3 root_position = {0, 0, 0};
  double root_pitch = 0;  // rotation about y: positive leans forward
  std::vector<std::pair<std::string, double>> angles;
  void Set(const std::string& hinge, double angle) { angles.emplace_back(hinge, angle); }
};

// Sagittal-plane leg: the hip, knee and ankle pitch that put the ankle at (dx, dz) from the hip
// (dz < 0), knee bending forward, for a pelvis pitched by `pitch`, with the foot pitched by
// `foot_pitch` in the world (0: flat; positive: toes down).
void SetLeg(Frame* f, const std::string& side, double dx, double dz, double pitch,
            double foot_pitch = 0) {
  double d = std::min(std::hypot(dx, dz), 0.999 * (kThigh + kShank));
  double knee =
      M_PI - std::acos((kThigh * kThigh + kShank * kShank - d * d) / (2 * kThigh * kShank));
  double toward_ankle = std::atan2(dx, -dz);  // forward angle of the hip-ankle line
  double thigh =
      toward_ankle + std::acos((kThigh * kThigh + d * d - kShank * kShank) / (2 * kThigh * d));
  // Hip flexion is -y; the foot's world pitch is the sum of pelvis, hip, knee and ankle pitch.
  f->Set(side + "_hip_y", -thigh - pitch);
  f->Set(side + "_knee", knee);
  f->Set(side + "_ankle_y", foot_pitch + thigh - knee);
}

// Legs for a standing pose with the ankles under the hips and knees bent by `knee`; returns the
// root height that puts the soles on the floor.
double SetStandingLegs(Frame* f, double knee) {
  double d = std::sqrt(kThigh * kThigh + kShank * kShank + 2 * kThigh * kShank * std::cos(knee));
  SetLeg(f, "right", 0, -d, 0);
  SetLeg(f, "left", 0, -d, 0);
  return d + kAnkleHeight;
}

// Arms hanging slightly away from the body, elbows a little bent.
void SetRestArms(Frame* f, double abduction, double elbow) {
  f->Set("right_shoulder_x", -abduction);
  f->Set("left_shoulder_x", abduction);
  f->Set("right_elbow", elbow);
  f->Set("left_elbow", elbow);
}

MotionClip Build(const Character& character, const std::string& name, double duration, double fps,
                 const Vec3& displacement, const std::function<Frame(double phase)>& pose_at) {
  const mjModel* m = character.model();
  int frames = static_cast<int>(std::lround(duration * fps));
  std::vector<Pose> poses;
  for (int i = 0; i <= frames; ++i) {
    // The last frame closes the cycle: the first pose, displaced by one cycle's travel.
    double phase = i == frames ? 0.0 : static_cast<double>(i) / frames;
    Frame f = pose_at(phase);
    std::vector<double> qpos(m->nq, 0.0);
    for (int k = 0; k < 3; ++k) qpos[k] = f.root_position[k] + (i == frames ? displacement[k] : 0);
    Quat root = AxisAngle({0, 1, 0}, f.root_pitch);
    for (int k = 0; k < 4; ++k) qpos[3 + k] = root[k];
    for (const auto& [hinge, angle] : f.angles) {
      int id = mj_name2id(m, mjOBJ_JOINT, hinge.c_str());
      qpos[m->jnt_qposadr[id]] = angle;
    }
    poses.push_back(character.QposToPose(qpos.data()));
  }
  std::vector<double> durations(poses.size(), duration / frames);
  return MotionClip(name, true, std::move(durations), std::move(poses));
}

// 0 -> 1 -> 0 over one period, smooth at both ends.
double Bump(double phase) { return 0.5 * (1 - std::cos(2 * M_PI * phase)); }

// 0 -> 1 over u in [0, 1] with zero slope at both ends (a foot's swing, a change of speed).
double Ramp(double u) { return u - std::sin(2 * M_PI * u) / (2 * M_PI); }

// The stand clip's knee bend, rad.
constexpr double kStandKnee = 0.08;

// The shipped walk, whose start and stop clips lead into and out of it: 0.9 m strides at one
// stride per second, each foot on the floor for 60 % of the cycle, the heel rising over the last
// 15 % of it onto the toe edge (pitch 0.35 rad at toe-off), swings 7 cm high. The pelvis is
// highest at mid-stance. Walk phase 0 is the right heel strike.
constexpr double kWalkStride = 0.9, kWalkCycle = 1.0, kWalkDuty = 0.6, kWalkHeelOff = 0.45;
constexpr double kWalkLift = 0.07;
constexpr double kWalkToeOff = 0.35;      // foot pitch at toe-off, rad
constexpr double kToeX = 0.045 + 0.0885;  // toe edge ahead of the ankle joint, m
constexpr double kWalkSpeed = kWalkStride / kWalkCycle;

// The walk's pelvis height at walk phase `phase`: 0.85 m, bobbing 3 cm, highest at mid-stance.
double WalkPelvisHeight(double phase) { return 0.85 + 0.015 * std::cos(4 * M_PI * (phase - 0.3)); }

// The walk's arms swing against the legs; the chest counter-rotates a little.
Frame WalkUpperBody(double phase) {
  Frame f;
  double swing = std::cos(2 * M_PI * phase);
  f.Set("right_shoulder_x", -0.1);
  f.Set("left_shoulder_x", 0.1);
  f.Set("right_shoulder_y", 0.3 * swing);
  f.Set("left_shoulder_y", -0.3 * swing);
  f.Set("right_elbow", 0.35 - 0.15 * swing);
  f.Set("left_elbow", 0.35 + 0.15 * swing);
  f.Set("chest_z", -0.06 * swing);
  return f;
}

// The stand clip's arms.
Frame StandUpperBody() {
  Frame f;
  SetRestArms(&f, 0.12, 0.15);
  return f;
}

// Hinge angles (1 - w) a + w b, a hinge missing from one frame taken as zero there.
Frame Blend(const Frame& a, const Frame& b, double w) {
  auto angle = [](const Frame& f, const std::string& hinge) {
    for (const auto& [name, value] : f.angles) {
      if (name == hinge) return value;
    }
    return 0.0;
  };
  std::vector<std::string> hinges;
  for (const Frame* f : {&a, &b}) {
    for (const auto& entry : f->angles) {
      if (std::find(hinges.begin(), hinges.end(), entry.first) == hinges.end()) {
        hinges.push_back(entry.first);
      }
    }
  }
  Frame out;
  for (const auto& hinge : hinges) out.Set(hinge, (1 - w) * angle(a, hinge) + w * angle(b, hinge));
  return out;
}

// ---- Gaits: the pelvis on a path, the feet planted on footholds, legs by inverse kinematics ----

// A pose on the floor: position and heading (yaw about +z).
struct PlanarPose {
  double x = 0, y = 0, yaw = 0;
  // The point (fx, fy) of this pose's frame, in the world.
  std::array<double, 2> Apply(double fx, double fy) const {
    double c = std::cos(yaw), s = std::sin(yaw);
    return {x + c * fx - s * fy, y + s * fx + c * fy};
  }
};

// The pose reached at time t moving with constant velocity (vx, vy) in the body's own frame and
// turning at rate w: an arc, or a straight line when w = 0.
PlanarPose Arc(double vx, double vy, double w, double t) {
  if (w == 0) return {vx * t, vy * t, 0};
  double along = std::sin(w * t) / w, across = (1 - std::cos(w * t)) / w;
  return {along * vx - across * vy, across * vx + along * vy, w * t};
}

// A foot on the floor from `land` to `lift` seconds: its ankle joint at (x, y, z), the sole flat,
// the foot turned to `yaw`. The swing that brings the foot here rises `swing_height` (m); when it
// leaves, the foot has rolled onto its toe edge to pitch `toe_off` (rad; 0: it lifts flat).
struct Foothold {
  double land = 0, lift = 0;
  double x = 0, y = 0, z = kAnkleHeight, yaw = 0;
  double swing_height = 0;
  double toe_off = 0;
};

// A foot: its ankle joint, heading and pitch (toes down > 0), and whether it is on the floor.
struct FootPose {
  Vec3 ankle = {0, 0, 0};
  double yaw = 0, pitch = 0;
  bool planted = true;
};

// The foot on `hold` with its heel raised to `pitch`, its toe edge still on the floor.
FootPose OnFoothold(const Foothold& hold, double pitch) {
  if (pitch == 0) return {{hold.x, hold.y, hold.z}, hold.yaw, 0};
  double forward = kToeX - kToeX * std::cos(pitch) + kAnkleHeight * std::sin(pitch);
  return {{hold.x + std::cos(hold.yaw) * forward, hold.y + std::sin(hold.yaw) * forward,
           hold.z + kToeX * std::sin(pitch) + kAnkleHeight * (std::cos(pitch) - 1)},
          hold.yaw,
          pitch};
}

// Where a foot stepping along `holds` (in time order) is at time t: planted, rolling onto its toe
// over the last `heel_rise` seconds of a stance that ends in a toe-off, or swinging from one
// foothold to the next along a smooth arc (as the walk's feet do).
FootPose FootAt(const std::vector<Foothold>& holds, double heel_rise, double t) {
  size_t k = 0;
  while (k + 1 < holds.size() && holds[k + 1].land <= t) ++k;
  const Foothold& hold = holds[k];
  if (t <= hold.lift || k + 1 == holds.size()) {
    double u = heel_rise > 0 ? (t - (hold.lift - heel_rise)) / heel_rise : -1;
    return OnFoothold(hold, u > 0 ? hold.toe_off * Ramp(std::min(u, 1.0)) : 0.0);
  }
  const Foothold& next = holds[k + 1];
  double u = (t - hold.lift) / (next.land - hold.lift);
  double s = Ramp(u);
  FootPose from = OnFoothold(hold, hold.toe_off), to = OnFoothold(next, 0);
  FootPose out;
  for (int i = 0; i < 3; ++i) out.ankle[i] = from.ankle[i] + (to.ankle[i] - from.ankle[i]) * s;
  out.ankle[2] += next.swing_height * Bump(u);
  out.yaw = from.yaw + std::remainder(to.yaw - from.yaw, 2 * M_PI) * s;
  out.pitch = from.pitch * (1 - s);
  out.planted = false;
  return out;
}

// A gait: the pelvis's path and height, each foot's footholds, and the upper body.
struct Gait {
  std::function<PlanarPose(double t)> pelvis;
  std::function<double(double t)> pelvis_height;
  std::array<std::vector<Foothold>, 2> footholds;  // right, left
  double heel_rise = 0;                            // s before a toe-off the heel starts rising
  // Chest, neck and arm hinges at time t, given both feet in the pelvis's frame.
  std::function<Frame(double t, const std::array<FootPose, 2>& feet)> upper_body;
};

// The worst a foot may miss its target by before authoring gives up. The gaits are designed
// within the legs' reach, except around the walk's heel strike, which the start and stop clips
// share with the walk: there the target lies just beyond a straight leg (docs/motion-import.md,
// "Authored clips").
constexpr double kMaxPlantedMiss = 0.002;  // m
constexpr double kMaxSwingMiss = 0.015;    // m
constexpr double kMaxMissAngle = 0.01;     // rad
// A swinging foot's ankle (its first hinge, ankle_y) stays this far inside its range, rad.
constexpr double kAnkleMargin = 0.05;

// The clip of a gait at kWalkFps key frames a second. A looping clip's last frame is its first
// moved by the pelvis's travel and turn over the cycle, so it closes the cycle exactly.
MotionClip BuildGait(const Character& character, const std::string& name, const Gait& gait,
                     double duration, bool loop) {
  const mjModel* m = character.model();
  DataPtr scratch = character.MakeData();
  // The inverse kinematics starts each frame from the standing legs, so every frame's solution
  // depends on its targets alone.
  Frame stand;
  SetStandingLegs(&stand, kStandKnee);
  const char* sides[] = {"right", "left"};
  int frames = static_cast<int>(std::lround(duration * kWalkFps));
  std::vector<Pose> poses;
  for (int i = 0; i <= frames; ++i) {
    if (loop && i == frames) {
      PlanarPose from = gait.pelvis(0), to = gait.pelvis(duration);
      Pose last = poses.front();
      last.root_position[0] += to.x - from.x;
      last.root_position[1] += to.y - from.y;
      last.root_rotation = Multiply(AxisAngle({0, 0, 1}, to.yaw - from.yaw), last.root_rotation);
      poses.push_back(std::move(last));
      break;
    }
    double t = duration * i / frames;
    PlanarPose pelvis = gait.pelvis(t);
    std::vector<double> qpos(m->nq, 0.0);
    qpos[0] = pelvis.x;
    qpos[1] = pelvis.y;
    qpos[2] = gait.pelvis_height(t);
    Quat root = AxisAngle({0, 0, 1}, pelvis.yaw);
    for (int k = 0; k < 4; ++k) qpos[3 + k] = root[k];
    std::array<FootPose, 2> feet, local;
    for (int side = 0; side < 2; ++side) {
      feet[side] = FootAt(gait.footholds[side], gait.heel_rise, t);
      local[side] = feet[side];
      double dx = feet[side].ankle[0] - pelvis.x, dy = feet[side].ankle[1] - pelvis.y;
      double c = std::cos(pelvis.yaw), s = std::sin(pelvis.yaw);
      local[side].ankle = {c * dx + s * dy, -s * dx + c * dy, feet[side].ankle[2] - qpos[2]};
      local[side].yaw = std::remainder(feet[side].yaw - pelvis.yaw, 2 * M_PI);
    }
    Frame f = gait.upper_body(t, local);
    for (const Frame* part : {&stand, &f}) {
      for (const auto& [hinge, angle] : part->angles) {
        qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, hinge.c_str())]] = angle;
      }
    }
    for (int side = 0; side < 2; ++side) {
      std::vector<double> start = qpos;
      LegIkResult r;
      // A swinging foot pitches as far as the ankle needs to stay within its range (a swing
      // behind a pelvis that is slowing down would otherwise ask for more than its 30 degrees
      // of dorsiflexion, and the leg would twist at the hip to make up for it).
      const int ankle = m->body_jntadr[character.BodyId(std::string(sides[side]) + "_ankle")];
      const double* range = m->jnt_range + 2 * ankle;
      double pitch = feet[side].pitch;
      for (int attempt = 0; attempt < 4; ++attempt) {
        qpos = start;
        Quat foot = Multiply(AxisAngle({0, 0, 1}, feet[side].yaw), AxisAngle({0, 1, 0}, pitch));
        r = SolveLegIk(character, sides[side], feet[side].ankle, foot, qpos.data(), scratch.get());
        double a = qpos[m->jnt_qposadr[ankle]];
        double excess = std::max(range[0] + kAnkleMargin - a, 0.0) -
                        std::max(a - (range[1] - kAnkleMargin), 0.0);
        if (feet[side].planted || excess == 0) break;
        pitch += excess;
      }
      double reach = feet[side].planted ? kMaxPlantedMiss : kMaxSwingMiss;
      if (r.position_error > reach || r.angle_error > kMaxMissAngle) {
        char message[200];
        std::snprintf(message, sizeof(message),
                      "%s: at %.3f s the %s foot is out of reach by %.1f mm, %.3f rad",
                      name.c_str(), t, sides[side], r.position_error * 1000, r.angle_error);
        throw std::logic_error(message);
      }
    }
    poses.push_back(character.QposToPose(qpos.data()));
  }
  std::vector<double> durations(poses.size(), duration / frames);
  return MotionClip(name, loop, std::move(durations), std::move(poses));
}

// The lateral offset of the hips from the pelvis centre (humanoid.xml), m.
double HipOffset(const Character& character) {
  return std::abs(character.model()->body_pos[3 * character.BodyId("left_hip") + 1]);
}

// A steady gait repeating every `cycle` seconds: the pelvis moves by (dx, dy) and turns by
// `turn` each cycle (both in its frame at the cycle's start) along an arc, at constant velocity
// in its own frame. Each foot is on the floor for `duty` of the cycle, the right landing at
// t = 0 and the left half a cycle later, and is planted, flat, where the pelvis is at its
// mid-stance, `width` to the side, facing the pelvis's heading then; it swings from one foothold
// to the next `lift` high. The pelvis bobs by `bob`, highest at mid-stance, and the arms swing
// against the feet, `arm_swing` rad of shoulder flexion per metre the feet are apart fore and aft.
struct SteadyGait {
  double cycle = 1, dx = 0, dy = 0, turn = 0;
  double duty = 0.6, width = 0.085, lift = 0.05;
  double pelvis_height = 0.86, bob = 0.01;
  double arm_swing = 0;
};

Gait MakeSteadyGait(const SteadyGait& spec) {
  // The body-frame velocity whose arc ends at (dx, dy) after one cycle.
  double w = spec.turn / spec.cycle, vx = spec.dx / spec.cycle, vy = spec.dy / spec.cycle;
  if (spec.turn != 0) {
    PlanarPose unit_x = Arc(1, 0, w, spec.cycle), unit_y = Arc(0, 1, w, spec.cycle);
    double det = unit_x.x * unit_y.y - unit_y.x * unit_x.y;
    vx = (unit_y.y * spec.dx - unit_y.x * spec.dy) / det;
    vy = (-unit_x.y * spec.dx + unit_x.x * spec.dy) / det;
  }
  Gait gait;
  gait.pelvis = [=](double t) { return Arc(vx, vy, w, t); };
  gait.pelvis_height = [spec](double t) {
    return spec.pelvis_height + spec.bob * std::cos(4 * M_PI * (t / spec.cycle - spec.duty / 2));
  };
  for (int side = 0; side < 2; ++side) {
    double offset = side == 0 ? -spec.width : spec.width;
    // Enough cycles either side of the clip for every swing in it to have both ends.
    for (int k = -2; k <= 3; ++k) {
      Foothold hold;
      hold.land = (k + 0.5 * side) * spec.cycle;
      hold.lift = hold.land + spec.duty * spec.cycle;
      PlanarPose at = gait.pelvis(hold.land + 0.5 * spec.duty * spec.cycle);
      auto [x, y] = at.Apply(0, offset);
      hold.x = x;
      hold.y = y;
      hold.yaw = at.yaw;
      hold.swing_height = spec.lift;
      gait.footholds[side].push_back(hold);
    }
  }
  gait.upper_body = [spec](double, const std::array<FootPose, 2>& feet) {
    Frame f;
    double swing = spec.arm_swing * (feet[0].ankle[0] - feet[1].ankle[0]);
    f.Set("right_shoulder_x", -0.1);
    f.Set("left_shoulder_x", 0.1);
    f.Set("right_shoulder_y", swing);
    f.Set("left_shoulder_y", -swing);
    f.Set("right_elbow", 0.3 - 0.5 * swing);
    f.Set("left_elbow", 0.3 + 0.5 * swing);
    f.Set("chest_z", -0.2 * swing);
    return f;
  };
  return gait;
}

// The walk's footholds along `pelvis`, at its timing with the walk at phase `phase0` at t = 0:
// each foot lands where the pelvis is at its mid-stance, under its hip, and leaves on its toe,
// pitched as far as `speed_fraction` at that moment allows (the walk's at full speed). A swing
// rises the walk's 7 cm, less for steps shorter than 30 cm. Footholds landing before
// `stand_until`, and those whose mid-stance comes at `stand_from` or later, are standing ones:
// at the height the stand clip's ankles have, and for the first, where the feet are at t = 0.
std::array<std::vector<Foothold>, 2> WalkFootholds(
    const std::function<PlanarPose(double)>& pelvis,
    const std::function<double(double)>& speed_fraction, double phase0, double width,
    double stand_until, double stand_from, double stand_ankle_height) {
  constexpr double kFullSwingStep = 0.3;  // m
  std::array<std::vector<Foothold>, 2> holds;
  for (int side = 0; side < 2; ++side) {
    double offset = side == 0 ? -width : width;
    for (int k = -2; k <= 4; ++k) {
      Foothold hold;
      hold.land = (k + 0.5 * side - phase0) * kWalkCycle;
      hold.lift = hold.land + kWalkDuty * kWalkCycle;
      double mid = hold.land + 0.5 * kWalkDuty * kWalkCycle;
      bool standing = hold.land < stand_until || mid >= stand_from;
      auto [x, y] = pelvis(hold.land < stand_until ? 0.0 : mid).Apply(0, offset);
      hold.x = x;
      hold.y = y;
      if (standing) hold.z = stand_ankle_height;
      hold.toe_off = kWalkToeOff * speed_fraction(hold.lift);
      if (!holds[side].empty()) {
        const Foothold& before = holds[side].back();
        double step = std::hypot(hold.x - before.x, hold.y - before.y);
        hold.swing_height = kWalkLift * std::min(1.0, step / kFullSwingStep);
      }
      holds[side].push_back(hold);
    }
  }
  return holds;
}

// The height of the ankle joints in the stand clip's pose: a little above kAnkleHeight, as
// SetLeg never straightens a leg fully. The clips that start or end standing stand so.
double StandAnkleHeight(const Character& character) {
  const mjModel* m = character.model();
  Frame f;
  std::vector<double> qpos(m->nq, 0.0);
  qpos[2] = SetStandingLegs(&f, kStandKnee);
  qpos[3] = 1;
  for (const auto& [hinge, angle] : f.angles) {
    qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, hinge.c_str())]] = angle;
  }
  DataPtr d = character.MakeData();
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  mj_kinematics(m, d.get());
  return d->xpos[3 * character.BodyId("right_ankle") + 2];
}

// The root height of the stand clip.
double StandHeight() {
  Frame f;
  return SetStandingLegs(&f, kStandKnee);
}

// The distance covered in time u T while speeding up from rest to speed v over T seconds along
// Ramp(): v T times the integral of Ramp from 0 to u.
double RampDistance(double v, double T, double u) {
  return v * T * (u * u / 2 + (std::cos(2 * M_PI * u) - 1) / (4 * M_PI * M_PI));
}

// stand: a relaxed upright pose held still; the task is balance alone.
AuthoredClip StandClip(const Character& character) {
  auto stand_pose = [](double) {
    Frame f;
    f.root_position[2] = SetStandingLegs(&f, kStandKnee);
    SetRestArms(&f, 0.12, 0.15);
    return f;
  };
  return {Build(character, "stand", 2.0, kFps, {0, 0, 0}, stand_pose),
          "Standing still, knees slightly bent, arms relaxed (static balance)."};
}

// arms: legs as in stand; the arms rise sideways to shoulder height and fall, one after the
// other, elbows waving.
AuthoredClip ArmsClip(const Character& character) {
  auto arms_pose = [](double phase) {
    Frame f;
    f.root_position[2] = SetStandingLegs(&f, 0.08);
    double right = Bump(phase), left = Bump(phase + 0.5);
    f.Set("right_shoulder_x", -(0.12 + 1.45 * right));
    f.Set("left_shoulder_x", 0.12 + 1.45 * left);
    f.Set("right_elbow", 0.15 + 0.9 * Bump(2 * phase));
    f.Set("left_elbow", 0.15 + 0.9 * Bump(2 * phase + 0.5));
    return f;
  };
  return {Build(character, "arms", 4.0, kFps, {0, 0, 0}, arms_pose),
          "Arm wave: each arm rises sideways to shoulder height and back, elbows "
          "bending, half a cycle apart; legs still."};
}

// squat: down to about 90 degrees of knee flexion and back up, feet flat and still; the
// pelvis moves back and the trunk and arms forward so the centre of mass stays over the feet.
AuthoredClip SquatClip(const Character& character) {
  auto squat_pose = [](double phase) {
    Frame f;
    double depth = Bump(phase);
    double knee = 0.08 + depth * (1.55 - 0.08);
    double shank = -0.45 * depth;  // forward lean of the shank (ankle dorsiflexion)
    double thigh = knee + shank;
    double pitch = 0.55 * depth;
    // Hip position relative to the ankle, from the segment angles.
    double hip_x = -kShank * std::sin(shank) - kThigh * std::sin(thigh);
    double hip_z = kShank * std::cos(shank) + kThigh * std::cos(thigh);
    f.root_position = {hip_x, 0, hip_z + kAnkleHeight};
    f.root_pitch = pitch;
    SetLeg(&f, "right", -hip_x, -hip_z, pitch);
    SetLeg(&f, "left", -hip_x, -hip_z, pitch);
    f.Set("chest_y", 0.15 * depth);
    f.Set("neck_y", -0.5 * depth);  // keep looking ahead
    f.Set("right_shoulder_x", -0.12);
    f.Set("left_shoulder_x", 0.12);
    f.Set("right_shoulder_y", -1.3 * depth - 0.2 * depth);
    f.Set("left_shoulder_y", -1.3 * depth - 0.2 * depth);
    f.Set("right_elbow", 0.15);
    f.Set("left_elbow", 0.15);
    return f;
  };
  return {Build(character, "squat", 4.0, kFps, {0, 0, 0}, squat_pose),
          "Squat: down to about 90 degrees of knee flexion and back up over 4 s, feet "
          "flat, arms reaching forward for balance."};
}

// walk: 0.9 m strides at one stride per second. Each foot is on the floor for 60 % of the
// cycle (two 10 % double-support phases): flat until 45 %, then the heel rises and the foot
// rolls over its toe edge, which stays put, to 20 degrees at toe-off. It swings along a smooth
// arc 7 cm high and lands flat. The pelvis moves forward at constant speed and bobs 3 cm,
// highest at mid-stance. Feet stay under the hips, so leg inverse kinematics in the sagittal
// plane is exact and a foot on the floor does not slide.
AuthoredClip WalkClip(const Character& character) {
  struct Foot {
    double x, z, pitch;  // ankle joint position and foot pitch (toes down > 0)
  };
  // Ankle position while the foot pivots on its toe edge at (toe_x, 0) with the given pitch.
  auto on_toe = [](double toe_x, double pitch) {
    return Foot{toe_x - kToeX * std::cos(pitch) + kAnkleHeight * std::sin(pitch),
                kToeX * std::sin(pitch) + kAnkleHeight * std::cos(pitch), pitch};
  };
  auto foot = [&on_toe](double psi) {  // psi: phase since this foot's heel strike
    const double planted = 0.3 * kWalkStride;
    if (psi < kWalkHeelOff) return Foot{planted, kAnkleHeight, 0};
    if (psi < kWalkDuty) {
      double u = (psi - kWalkHeelOff) / (kWalkDuty - kWalkHeelOff);
      return on_toe(planted + kToeX, kWalkToeOff * Ramp(u));
    }
    Foot start = on_toe(planted + kToeX, kWalkToeOff);
    double u = (psi - kWalkDuty) / (1 - kWalkDuty);
    double s = Ramp(u);
    return Foot{start.x + (planted + kWalkStride - start.x) * s,
                start.z + (kAnkleHeight - start.z) * s + kWalkLift * Bump(u),
                kWalkToeOff * (1 - s)};
  };
  auto walk_pose = [&foot](double phase) {
    Frame f;
    double pelvis_x = kWalkStride * phase;
    double pelvis_z = WalkPelvisHeight(phase);
    f.root_position = {pelvis_x, 0, pelvis_z};
    Foot right = foot(phase);
    double psi = phase - 0.5;  // the left foot strikes half a cycle later
    double shift = 0.5 * kWalkStride;
    if (psi < 0) {
      psi += 1;
      shift -= kWalkStride;
    }
    Foot left = foot(psi);
    left.x += shift;
    SetLeg(&f, "right", right.x - pelvis_x, right.z - pelvis_z, 0, right.pitch);
    SetLeg(&f, "left", left.x - pelvis_x, left.z - pelvis_z, 0, left.pitch);
    for (const auto& [hinge, angle] : WalkUpperBody(phase).angles) f.Set(hinge, angle);
    return f;
  };
  return {Build(character, "walk", kWalkCycle, kWalkFps, {kWalkStride, 0, 0}, walk_pose),
          "Walk: 0.9 m strides at 1 stride/s (0.9 m/s), 60 % stance per foot with heel "
          "rise onto the toes, planted feet still, arms swinging against the legs."};
}

// The motion set of a steerable character: the gaits below share one generator (the pelvis on an
// arc, each foot planted where the pelvis is at its mid-stance, legs by inverse kinematics), at
// the walk's 60 key frames a second.

// walk_backward: 0.5 m strides at one stride per second, flat-footed, arms swinging gently.
AuthoredClip WalkBackwardClip(const Character& character) {
  const double hips = HipOffset(character);
  SteadyGait backward;
  backward.cycle = 1.0;
  backward.dx = -0.5;
  backward.width = hips;
  backward.arm_swing = 0.6;
  return {BuildGait(character, "walk_backward", MakeSteadyGait(backward), 1.0, true),
          "Backward walk: 0.5 m strides at 1 stride/s (0.5 m/s), 60 % stance per "
          "foot, flat-footed steps 5 cm high, planted feet still, arms swinging gently "
          "against the legs."};
}

// strafe_left: side steps to the left at 0.4 m/s, facing forward. Both feet step 0.32 m per
// 0.8 s cycle; a stance 15 cm to each side of the pelvis keeps the closing foot 14 cm from the
// other when they are nearest.
AuthoredClip StrafeLeftClip(const Character& character) {
  SteadyGait strafe;
  strafe.cycle = 0.8;
  strafe.dy = 0.32;
  strafe.width = 0.15;
  strafe.pelvis_height = 0.85;
  return {BuildGait(character, "strafe_left", MakeSteadyGait(strafe), 0.8, true),
          "Side steps to the left: 0.32 m per 0.8 s cycle (0.4 m/s), facing forward, "
          "legs stepping apart and together, feet parallel, 60 % stance per foot."};
}

// turn_left: stepping in place while turning counter-clockwise, 90 degrees per 1.5 s cycle;
// each foot is planted turned to the pelvis's heading at its mid-stance.
AuthoredClip TurnLeftClip(const Character& character) {
  SteadyGait turn;
  turn.cycle = 1.5;
  turn.turn = M_PI / 2;
  turn.width = 0.12;
  turn.bob = 0.005;
  turn.arm_swing = 0.6;
  return {BuildGait(character, "turn_left", MakeSteadyGait(turn), 1.5, true),
          "Turning left on the spot: 90 degrees counter-clockwise per 1.5 s cycle "
          "(60 deg/s), stepping in place onto footholds turned with the pelvis, 60 % "
          "stance per foot, the root staying over the same point."};
}

// walk_start: from the stand clip's pose into the walk. The pelvis speeds up smoothly to
// walking speed over 0.9 s, lowering to walking height in the first 0.5 s; the right foot
// steps first, half a stride, the left follows with a nearly full one. The clip ends 1.2 s
// in, at walk phase 0.6 (the right toe-off), in the walk's pose at the walk's speed.
AuthoredClip WalkStartClip(const Character& character) {
  const double hips = HipOffset(character);
  constexpr double kStartPhase = 0.4, kAccelerate = 0.9, kLower = 0.5;
  const double stand_height = StandHeight();
  Gait start;
  start.pelvis = [](double t) -> PlanarPose {
    double u = std::clamp(t / kAccelerate, 0.0, 1.0);
    return {RampDistance(kWalkSpeed, kAccelerate, u) + kWalkSpeed * std::max(t - kAccelerate, 0.0),
            0, 0};
  };
  auto start_speed = [](double t) { return Ramp(std::clamp(t / kAccelerate, 0.0, 1.0)); };
  start.pelvis_height = [stand_height](double t) {
    double lowered = Ramp(std::clamp(t / kLower, 0.0, 1.0));
    return stand_height + lowered * (WalkPelvisHeight(kStartPhase + t) - stand_height);
  };
  const double stand_ankle = StandAnkleHeight(character);
  start.footholds = WalkFootholds(start.pelvis, start_speed, kStartPhase, hips,
                                  (kWalkDuty - kStartPhase) * kWalkCycle, INFINITY, stand_ankle);
  start.heel_rise = (kWalkDuty - kWalkHeelOff) * kWalkCycle;
  start.upper_body = [start_speed](double t, const std::array<FootPose, 2>&) {
    return Blend(StandUpperBody(), WalkUpperBody(kStartPhase + t), start_speed(t));
  };
  return {BuildGait(character, "walk_start", start, 1.2, false),
          "Starting to walk: from the stand pose (stand's first frame), speeding up "
          "smoothly to the walk's 0.9 m/s over 0.9 s, right foot first with a half "
          "stride; ends at 1.2 s in the walk's pose at walk phase 0.6 (walk.json frame "
          "36, the right toe-off)."};
}

// walk_stop: from the walk at phase 0.6 (the right toe-off) to the stand pose. The pelvis
// keeps walking speed for 0.2 s, so that the first frame is the walk's, then slows down
// smoothly over 1 s to a stop 0.63 m from where it started; the left foot lands under it, the
// right short of it and closes up beside the left with a small last step, and the pelvis rises
// to standing height over the last 0.6 s. The clip ends at 1.5 s in the stand clip's pose.
AuthoredClip WalkStopClip(const Character& character) {
  const double hips = HipOffset(character);
  const double stand_height = StandHeight();
  const double stand_ankle = StandAnkleHeight(character);
  constexpr double kStopPhase = 0.6, kKeep = 0.2, kDecelerate = 1.0, kRaise = 0.6;
  constexpr double kStopLength = 1.5;
  Gait stop;
  stop.pelvis = [=](double t) -> PlanarPose {
    double u = std::clamp((t - kKeep) / kDecelerate, 0.0, 1.0);
    return {kWalkSpeed * std::min(t, kKeep) + kWalkSpeed * kDecelerate * u -
                RampDistance(kWalkSpeed, kDecelerate, u),
            0, 0};
  };
  auto stop_speed = [](double t) {
    return 1 - Ramp(std::clamp((t - kKeep) / kDecelerate, 0.0, 1.0));
  };
  stop.pelvis_height = [stand_height](double t) {
    double raised = Ramp(std::clamp((t - (kStopLength - kRaise)) / kRaise, 0.0, 1.0));
    return stand_height + (1 - raised) * (WalkPelvisHeight(kStopPhase + t) - stand_height);
  };
  stop.footholds = WalkFootholds(stop.pelvis, stop_speed, kStopPhase, hips, -INFINITY,
                                 kKeep + kDecelerate, stand_ankle);
  stop.heel_rise = (kWalkDuty - kWalkHeelOff) * kWalkCycle;
  stop.upper_body = [stop_speed](double t, const std::array<FootPose, 2>&) {
    return Blend(StandUpperBody(), WalkUpperBody(kStopPhase + t), stop_speed(t));
  };
  return {BuildGait(character, "walk_stop", stop, kStopLength, false),
          "Stopping from the walk: starts in the walk's pose at walk phase 0.6 "
          "(walk.json frame 36, the right toe-off) at 0.9 m/s, slows down smoothly to "
          "a stop 0.63 m on within 1.2 s, the right foot closing up beside the left; "
          "ends at 1.5 s in the stand pose."};
}

}  // namespace

std::vector<AuthoredClip> AuthorClips(const Character& character) {
  return {StandClip(character),    ArmsClip(character),         SquatClip(character),
          WalkClip(character),     WalkBackwardClip(character), StrafeLeftClip(character),
          TurnLeftClip(character), WalkStartClip(character),    WalkStopClip(character)};
}

}  // namespace ragdoll::motion
