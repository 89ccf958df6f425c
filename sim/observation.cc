#include "sim/observation.h"

#include <cmath>

#include "character/character.h"
#include "character/rotation.h"

namespace ragdoll::sim {
namespace {

constexpr int kRootSize = 1 + 6 + 3 + 3;
constexpr int kBodySize = 3 + 6 + 3 + 3;
constexpr int kPhaseSize = 3;

// Writes the first two columns of rotation matrix (heading^-1 * body) as 6 floats.
float* PutRotation(const double* heading_inverse, const double* body_quat, float* out) {
  double q[4], m[9];
  mju_mulQuat(q, heading_inverse, body_quat);
  mju_quat2Mat(m, q);
  for (int col = 0; col < 2; ++col) {
    for (int row = 0; row < 3; ++row) *out++ = static_cast<float>(m[3 * row + col]);
  }
  return out;
}

float* PutVector(const double* heading_inverse, const double* v, float* out) {
  double r[3];
  mju_rotVecQuat(r, v, heading_inverse);
  for (double c : r) *out++ = static_cast<float>(c);
  return out;
}

}  // namespace

int ObservationSize(const character::Character& character) {
  return kRootSize + kBodySize * (static_cast<int>(character.bodies().size()) - 1) + kPhaseSize;
}

std::vector<std::string> ObservationNames(const character::Character& character) {
  const mjModel* m = character.model();
  std::vector<std::string> names;
  auto add = [&names](const std::string& prefix, const char* parts) {
    for (const char* p = parts; *p; ++p) names.push_back(prefix + "." + *p);
  };
  auto add_rotation = [&names](const std::string& prefix) {
    for (const char* c : {"xx", "yx", "zx", "xy", "yy", "zy"})
      names.push_back(prefix + ".rot." + c);
  };
  names.push_back("root.height");
  add_rotation("root");
  add("root.vel", "xyz");
  add("root.angvel", "xyz");
  for (size_t i = 1; i < character.bodies().size(); ++i) {
    std::string body = mj_id2name(m, mjOBJ_BODY, character.bodies()[i]);
    add(body + ".pos", "xyz");
    add_rotation(body);
    add(body + ".vel", "xyz");
    add(body + ".angvel", "xyz");
  }
  names.push_back("phase");
  names.push_back("phase.sin");
  names.push_back("phase.cos");
  return names;
}

void BuildObservation(const character::Character& character, const mjData& data, double phase,
                      float* out) {
  const mjModel* m = character.model();
  const int root = character.root_body();
  const double* root_pos = data.xpos + 3 * root;
  const double* root_quat = data.xquat + 4 * root;
  character::Quat root_rotation = {root_quat[0], root_quat[1], root_quat[2], root_quat[3]};
  character::Quat heading_inverse = character::Conjugate(character::HeadingOf(root_rotation));

  double velocity[6];  // (angular, linear) at the body origin, world axes
  *out++ = static_cast<float>(root_pos[2]);
  out = PutRotation(heading_inverse.data(), root_quat, out);
  mj_objectVelocity(m, &data, mjOBJ_BODY, root, velocity, 0);
  out = PutVector(heading_inverse.data(), velocity + 3, out);
  out = PutVector(heading_inverse.data(), velocity, out);

  for (size_t i = 1; i < character.bodies().size(); ++i) {
    int b = character.bodies()[i];
    double offset[3];
    mju_sub3(offset, data.xpos + 3 * b, root_pos);
    out = PutVector(heading_inverse.data(), offset, out);
    out = PutRotation(heading_inverse.data(), data.xquat + 4 * b, out);
    mj_objectVelocity(m, &data, mjOBJ_BODY, b, velocity, 0);
    out = PutVector(heading_inverse.data(), velocity + 3, out);
    out = PutVector(heading_inverse.data(), velocity, out);
  }
  *out++ = static_cast<float>(phase);
  *out++ = static_cast<float>(std::sin(2 * M_PI * phase));
  *out++ = static_cast<float>(std::cos(2 * M_PI * phase));
}

}  // namespace ragdoll::sim
