#include "motion/clip_kind.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include "character/skeleton.h"

namespace ragdoll::motion {

using character::MotionClip;
using character::Pose;

namespace {

double Degrees(double radians) { return radians * 180 / M_PI; }

// The root's tilt: its rotation with the heading taken out.
character::Quat Tilt(const character::Quat& root) {
  return character::Multiply(character::Conjugate(character::HeadingOf(root)), root);
}

bool IsFoot(const std::string& body) {
  return body.find("ankle") != std::string::npos || body.find("toe") != std::string::npos ||
         body.find("foot") != std::string::npos;
}

}  // namespace

bool ClosesALoop(const MotionClip& clip, std::string* why) {
  const Pose& first = clip.frame(0);
  const Pose& last = clip.frame(clip.num_frames() - 1);
  char line[200];
  auto say = [&](bool result) {
    if (why != nullptr) *why = line;
    return result;
  };
  double worst = 0, sum = 0;
  std::string joint;
  const std::vector<character::SkeletonJoint>& joints = character::Humanoid3dJoints();
  for (size_t j = 0; j < first.joint_rotations.size(); ++j) {
    const double angle =
        Degrees(character::AngleBetween(first.joint_rotations[j], last.joint_rotations[j]));
    sum += angle;
    if (angle > worst) {
      worst = angle;
      joint = j < joints.size() ? joints[j].name : std::to_string(j);
    }
  }
  const double mean = first.joint_rotations.empty() ? 0 : sum / first.joint_rotations.size();
  std::snprintf(line, sizeof line,
                "the last frame's joints are %.1f deg from the first's on average, its %s %.0f",
                mean, joint.c_str(), worst);
  if (mean > kLoopMeanDegrees || worst > kLoopJointDegrees) return say(false);
  const double height = std::fabs(last.root_position[2] - first.root_position[2]);
  if (height > kLoopHeight) {
    std::snprintf(line, sizeof line, "the root ends %.0f cm %s than it starts", 100 * height,
                  last.root_position[2] > first.root_position[2] ? "higher" : "lower");
    return say(false);
  }
  const double tilt =
      Degrees(character::AngleBetween(Tilt(first.root_rotation), Tilt(last.root_rotation)));
  if (tilt > kLoopMeanDegrees) {
    std::snprintf(line, sizeof line, "the body ends tilted %.0f deg from how it starts", tilt);
    return say(false);
  }
  std::snprintf(line, sizeof line,
                "the last frame is the first pose again (its joints %.1f deg from the first's on "
                "average, its %s %.0f)",
                mean, joint.c_str(), worst);
  return say(true);
}

MotionClip AsLoop(const MotionClip& clip) {
  std::vector<Pose> frames;
  std::vector<double> durations;
  for (int f = 0; f < clip.num_frames(); ++f) {
    frames.push_back(clip.frame(f));
    durations.push_back(clip.frame_duration(f));
  }
  return MotionClip(clip.name(), true, std::move(durations), std::move(frames),
                    clip.cycle_transform());
}

ClipKindChoice ClassifyClip(const MotionClip& clip, const ClipReport& report) {
  char line[300];
  for (const auto& [body, share] : report.ground_contacts) {
    if (IsFoot(body) || share < kContactShare) continue;
    std::snprintf(line, sizeof line, "its %s is on the floor in %.0f %% of frames", body.c_str(),
                  100 * share);
    return {ClipKind::kContactRich, "contact-rich", "action.yaml", line};
  }
  if (!clip.loop()) {
    std::snprintf(line, sizeof line, "it plays once (%.2f s)", clip.duration());
    return {ClipKind::kAction, "one-shot action", "action.yaml", line};
  }
  const double speed =
      std::hypot(clip.cycle_displacement()[0], clip.cycle_displacement()[1]) / clip.duration();
  const double turn = std::fabs(clip.cycle_yaw());
  std::snprintf(line, sizeof line,
                "a loop of %.2f s whose root travels %.2f m/s and turns %.0f deg", clip.duration(),
                speed, Degrees(turn));
  if (speed >= kLocomotionSpeed || turn >= kLocomotionTurn) {
    return {ClipKind::kLocomotion, "looping locomotion", "walk.yaml", line};
  }
  return {ClipKind::kInPlace, "loop in place", "stand.yaml", line};
}

}  // namespace ragdoll::motion
