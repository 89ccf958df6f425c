#include "sim/falls.h"

#include <algorithm>
#include <cmath>

#include "character/rotation.h"

namespace ragdoll::sim {

const char* PostureName(Posture posture) {
  switch (posture) {
    case Posture::kStanding:
      return "standing";
    case Posture::kFaceDown:
      return "face down";
    case Posture::kFaceUp:
      return "face up";
    case Posture::kSide:
      return "side";
    case Posture::kOther:
      break;
  }
  return "other";
}

Posture PostureOf(const character::Character& character, const mjData& d, double stand_height) {
  const int root = character.root_body();
  const double* r = d.xmat + 9 * root;
  const double up_z = r[8];     // the trunk's own up (+z) axis, its world z
  const double front_z = r[6];  // its front (+x)
  if (up_z > std::cos(30 * M_PI / 180) && d.xpos[3 * root + 2] > stand_height) {
    return Posture::kStanding;
  }
  if (std::abs(up_z) > std::sin(45 * M_PI / 180)) return Posture::kOther;
  if (front_z < -0.5) return Posture::kFaceDown;
  if (front_z > 0.5) return Posture::kFaceUp;
  return Posture::kSide;
}

double StandHeight(const character::MotionClip& clip) {
  return 0.8 * clip.Sample(0).root_position[2];
}

FallenState SettledFall(const character::Character& character, const character::MotionClip& clip,
                        std::mt19937_64& rng) {
  const mjModel* m = character.model();
  std::uniform_real_distribution<double> unit(0, 1);
  character::Pose pose = clip.Sample(unit(rng) * clip.duration());
  // Face down: the front turned to the floor about the lateral (+y) axis; face up the other way;
  // the sides about the front (+x) axis.
  const int lay = std::uniform_int_distribution<int>(0, 3)(rng);
  const character::Vec3 axis = lay < 2 ? character::Vec3{0, 1, 0} : character::Vec3{1, 0, 0};
  const double jitter = (2 * unit(rng) - 1) * 20 * M_PI / 180;
  const double angle = (lay % 2 == 0 ? 1 : -1) * M_PI / 2 + jitter;
  pose.root_rotation = character::Multiply(character::AxisAngle({0, 0, 1}, 2 * M_PI * unit(rng)),
                                           character::AxisAngle(axis, angle));
  pose.root_position = {0, 0, 0};
  pose.root_position[2] = 0.25 - character.LowestPoint(pose);

  character::DataPtr data = character.MakeData();
  mjData* d = data.get();
  character.PoseToQpos(pose, d->qpos);
  mj_forward(m, d);
  const int still_steps = std::max(1, static_cast<int>(std::lround(0.2 / m->opt.timestep)));
  const int max_steps = static_cast<int>(std::lround(4.0 / m->opt.timestep));
  int still = 0, step = 0;
  for (; step < max_steps && still < still_steps; ++step) {
    for (const character::ActuatedHinge& h : character.hinges())
      d->ctrl[h.actuator] = d->qpos[h.qpos_address];
    mj_step(m, d);
    double fastest = 0;
    for (int i = 0; i < m->nv; ++i) fastest = std::max(fastest, std::abs(d->qvel[i]));
    still = fastest < 0.3 ? still + 1 : 0;
  }
  FallenState s;
  s.qpos.assign(d->qpos, d->qpos + m->nq);
  s.qvel.assign(d->qvel, d->qvel + m->nv);
  s.seconds = step * m->opt.timestep;
  s.posture = PostureOf(character, *d, 0);
  return s;
}

}  // namespace ragdoll::sim
