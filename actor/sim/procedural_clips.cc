#include "actor/sim/procedural_clips.h"

#include <algorithm>
#include <cmath>
#include <functional>

namespace ragdoll::sim {
namespace {

// Key frames per second. The walk uses more: its legs move fast enough that interpolating
// joint rotations between 30 fps key frames lets a planted sole dip 7 mm into the floor.
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
    Pose pose;
    pose.root_position = {qpos[0], qpos[1], qpos[2]};
    pose.root_rotation = root;
    for (size_t j = 0; j < character.joints().size(); ++j) {
      pose.joint_rotations.push_back(character.JointRotation(qpos.data(), static_cast<int>(j)));
    }
    poses.push_back(std::move(pose));
  }
  std::vector<double> durations(poses.size(), duration / frames);
  return MotionClip(name, true, std::move(durations), std::move(poses));
}

// 0 -> 1 -> 0 over one period, smooth at both ends.
double Bump(double phase) { return 0.5 * (1 - std::cos(2 * M_PI * phase)); }

}  // namespace

std::vector<AuthoredClip> AuthorClips(const Character& character) {
  std::vector<AuthoredClip> clips;

  // stand: a relaxed upright pose held still; the task is balance alone.
  auto stand_pose = [](double) {
    Frame f;
    f.root_position[2] = SetStandingLegs(&f, 0.08);
    SetRestArms(&f, 0.12, 0.15);
    return f;
  };
  clips.push_back({Build(character, "stand", 2.0, kFps, {0, 0, 0}, stand_pose),
                   "Standing still, knees slightly bent, arms relaxed (static balance)."});

  // arms: legs as in stand; the arms rise sideways to shoulder height and fall, one after the
  // other, elbows waving.
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
  clips.push_back({Build(character, "arms", 4.0, kFps, {0, 0, 0}, arms_pose),
                   "Arm wave: each arm rises sideways to shoulder height and back, elbows "
                   "bending, half a cycle apart; legs still."});

  // squat: down to about 90 degrees of knee flexion and back up, feet flat and still; the
  // pelvis moves back and the trunk and arms forward so the centre of mass stays over the feet.
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
  clips.push_back({Build(character, "squat", 4.0, kFps, {0, 0, 0}, squat_pose),
                   "Squat: down to about 90 degrees of knee flexion and back up over 4 s, feet "
                   "flat, arms reaching forward for balance."});

  // walk: 0.9 m strides at one stride per second. Each foot is on the floor for 60 % of the
  // cycle (two 10 % double-support phases): flat until 45 %, then the heel rises and the foot
  // rolls over its toe edge, which stays put, to 20 degrees at toe-off. It swings along a smooth
  // arc 7 cm high and lands flat. The pelvis moves forward at constant speed and bobs 3 cm,
  // highest at mid-stance. Feet stay under the hips, so leg inverse kinematics in the sagittal
  // plane is exact and a foot on the floor does not slide.
  constexpr double kStride = 0.9, kCycle = 1.0, kDuty = 0.6, kHeelOff = 0.45, kLift = 0.07;
  constexpr double kToeOff = 0.35;          // foot pitch at toe-off, rad
  constexpr double kToeX = 0.045 + 0.0885;  // toe edge ahead of the ankle joint, m
  struct Foot {
    double x, z, pitch;  // ankle joint position and foot pitch (toes down > 0)
  };
  // Ankle position while the foot pivots on its toe edge at (toe_x, 0) with the given pitch.
  auto on_toe = [](double toe_x, double pitch) {
    return Foot{toe_x - kToeX * std::cos(pitch) + kAnkleHeight * std::sin(pitch),
                kToeX * std::sin(pitch) + kAnkleHeight * std::cos(pitch), pitch};
  };
  auto foot = [&on_toe](double psi) {  // psi: phase since this foot's heel strike
    const double planted = 0.3 * kStride;
    auto ramp = [](double u) { return u - std::sin(2 * M_PI * u) / (2 * M_PI); };  // 0 -> 1
    if (psi < kHeelOff) return Foot{planted, kAnkleHeight, 0};
    if (psi < kDuty) {
      double u = (psi - kHeelOff) / (kDuty - kHeelOff);
      return on_toe(planted + kToeX, kToeOff * ramp(u));
    }
    Foot start = on_toe(planted + kToeX, kToeOff);
    double u = (psi - kDuty) / (1 - kDuty);
    double s = ramp(u);
    return Foot{start.x + (planted + kStride - start.x) * s,
                start.z + (kAnkleHeight - start.z) * s + kLift * Bump(u), kToeOff * (1 - s)};
  };
  auto walk_pose = [&foot](double phase) {
    Frame f;
    double pelvis_x = kStride * phase;
    double pelvis_z = 0.85 + 0.015 * std::cos(4 * M_PI * (phase - 0.3));
    f.root_position = {pelvis_x, 0, pelvis_z};
    Foot right = foot(phase);
    double psi = phase - 0.5;  // the left foot strikes half a cycle later
    double shift = 0.5 * kStride;
    if (psi < 0) {
      psi += 1;
      shift -= kStride;
    }
    Foot left = foot(psi);
    left.x += shift;
    SetLeg(&f, "right", right.x - pelvis_x, right.z - pelvis_z, 0, right.pitch);
    SetLeg(&f, "left", left.x - pelvis_x, left.z - pelvis_z, 0, left.pitch);
    // Arms swing against the legs; the chest counter-rotates a little.
    double swing = std::cos(2 * M_PI * phase);
    f.Set("right_shoulder_x", -0.1);
    f.Set("left_shoulder_x", 0.1);
    f.Set("right_shoulder_y", 0.3 * swing);
    f.Set("left_shoulder_y", -0.3 * swing);
    f.Set("right_elbow", 0.35 - 0.15 * swing);
    f.Set("left_elbow", 0.35 + 0.15 * swing);
    f.Set("chest_z", -0.06 * swing);
    return f;
  };
  clips.push_back({Build(character, "walk", kCycle, kWalkFps, {kStride, 0, 0}, walk_pose),
                   "Walk: 0.9 m strides at 1 stride/s (0.9 m/s), 60 % stance per foot with heel "
                   "rise onto the toes, planted feet still, arms swinging against the legs."});
  return clips;
}

}  // namespace ragdoll::sim
