#include "character/ground_contacts.h"

#include <algorithm>

namespace ragdoll::character {

std::vector<std::pair<std::string, double>> GroundContactFractions(const MotionClip& clip,
                                                                   const Character& character,
                                                                   double height) {
  const mjModel* m = character.model();
  DataPtr d = character.MakeData();
  const int frames = clip.num_frames();
  std::vector<int> body_contact_frames(m->nbody, 0);
  for (int f = 0; f < frames; ++f) {
    character.PoseToQpos(clip.frame(f), d->qpos);
    mj_kinematics(m, d.get());
    std::vector<char> touches(m->nbody, 0);
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] == 0) continue;
      if (GeomLowestPoint(m, d.get(), g) < height) touches[m->geom_bodyid[g]] = 1;
    }
    for (int b = 0; b < m->nbody; ++b) body_contact_frames[b] += touches[b];
  }
  std::vector<std::pair<std::string, double>> contacts;
  for (int b : character.bodies()) {
    if (body_contact_frames[b] > 0) {
      contacts.emplace_back(mj_id2name(m, mjOBJ_BODY, b),
                            static_cast<double>(body_contact_frames[b]) / frames);
    }
  }
  return contacts;
}

std::vector<std::string> ClipGroundContacts(const MotionClip& clip, const Character& character) {
  const std::vector<std::pair<std::string, double>> contacts =
      GroundContactFractions(clip, character);
  std::vector<std::string> bodies;
  for (int b : character.bodies()) {
    const std::string name = mj_id2name(character.model(), mjOBJ_BODY, b);
    bool feet = name == "right_ankle" || name == "left_ankle";
    bool touches = std::any_of(contacts.begin(), contacts.end(),
                               [&](const auto& c) { return c.first == name; });
    if (feet || touches) bodies.push_back(name);
  }
  return bodies;
}

namespace {

// The body a contact puts on the floor (body 0, the world), or -1 for a contact elsewhere.
int BodyOnGround(const mjModel* m, const mjContact& contact) {
  const int b1 = m->geom_bodyid[contact.geom1];
  const int b2 = m->geom_bodyid[contact.geom2];
  const int other = b1 == 0 ? b2 : (b2 == 0 ? b1 : -1);
  return other > 0 ? other : -1;
}

}  // namespace

void BodiesOnGround(const mjModel* m, const mjData& d, std::vector<char>* on) {
  on->assign(m->nbody, 0);
  for (int i = 0; i < d.ncon; ++i) {
    const int body = BodyOnGround(m, d.contact[i]);
    if (body > 0) (*on)[body] = 1;
  }
}

bool TouchesGroundOutside(const mjModel* m, const mjData& d, const std::vector<char>& may_touch) {
  for (int i = 0; i < d.ncon; ++i) {
    const int body = BodyOnGround(m, d.contact[i]);
    if (body > 0 && !may_touch[body]) return true;
  }
  return false;
}

}  // namespace ragdoll::character
