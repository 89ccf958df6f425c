#include "character/character.h"

#include <algorithm>
#include <cmath>

#include "character/skeleton.h"
#include "common/config_section.h"

namespace ragdoll::character {
namespace {

const char* kBodyOrder[] = {"root",          "chest",       "neck",           "right_hip",
                            "right_knee",    "right_ankle", "right_shoulder", "right_elbow",
                            "right_wrist",   "left_hip",    "left_knee",      "left_ankle",
                            "left_shoulder", "left_elbow",  "left_wrist"};
const char* kEndEffectors[] = {"right_wrist", "left_wrist", "right_ankle", "left_ankle"};

// The bodies of kBodyOrder, in that order.
std::vector<int> SkeletonBodies(const mjModel* m, const std::string& path) {
  std::vector<int> bodies;
  for (const char* name : kBodyOrder) {
    int id = mj_name2id(m, mjOBJ_BODY, name);
    if (id < 0) ThrowConfigError(path, std::string("missing body '") + name + "'");
    bodies.push_back(id);
  }
  return bodies;
}

// MuJoCo joint `jnt` as the actuated hinge `name` of skeleton joint `joint`, its actuator checked
// (`where` names it in errors).
ActuatedHinge BuildHinge(const mjModel* m, int jnt, const char* name, int joint,
                         const std::string& path, const std::string& where) {
  ActuatedHinge hinge;
  hinge.name = name;
  hinge.joint = joint;
  hinge.qpos_address = m->jnt_qposadr[jnt];
  hinge.dof_address = m->jnt_dofadr[jnt];
  hinge.lower = m->jnt_range[2 * jnt];
  hinge.upper = m->jnt_range[2 * jnt + 1];
  hinge.actuator = -1;
  for (int a = 0; a < m->nu; ++a) {
    if (m->actuator_trntype[a] == mjTRN_JOINT && m->actuator_trnid[2 * a] == jnt) {
      hinge.actuator = a;
    }
  }
  if (hinge.actuator < 0) ThrowConfigError(path, where + ": has no actuator");
  // A position actuator: force = kp * (ctrl - q), i.e. gain kp and bias (0, -kp, *).
  int a = hinge.actuator;
  if (m->actuator_gaintype[a] != mjGAIN_FIXED || m->actuator_biastype[a] != mjBIAS_AFFINE ||
      m->actuator_biasprm[mjNBIAS * a + 1] != -m->actuator_gainprm[mjNGAIN * a]) {
    ThrowConfigError(path, where + ": its actuator must be a <position> actuator (a PD target)");
  }
  return hinge;
}

// Skeleton joint `sj` (the `index`th) as built on MuJoCo body `body`; appends its actuated hinges
// to `hinges`.
CharacterJoint BuildJoint(const mjModel* m, const SkeletonJoint& sj, int body, int index,
                          std::vector<ActuatedHinge>* hinges, const std::string& path) {
  CharacterJoint joint;
  joint.name = sj.name;
  joint.body = body;
  int expected = sj.type == JointType::kSpherical ? 3 : 1;
  if (m->body_jntnum[joint.body] != expected) {
    ThrowConfigError(
        path, "joint '" + sj.name + "' must be built of " + std::to_string(expected) + " hinge(s)");
  }
  joint.axes.count = expected;
  int first = m->body_jntadr[joint.body];
  joint.qpos_address = m->jnt_qposadr[first];
  joint.dof_address = m->jnt_dofadr[first];
  bool used[3] = {false, false, false};
  for (int h = 0; h < expected; ++h) {
    int jnt = first + h;
    const char* hname = mj_id2name(m, mjOBJ_JOINT, jnt);
    std::string where = "joint '" + sj.name + "' hinge " + (hname ? hname : "?");
    if (m->jnt_type[jnt] != mjJNT_HINGE) ThrowConfigError(path, where + ": must be a hinge");
    if (!m->jnt_limited[jnt]) ThrowConfigError(path, where + ": must have a range");
    // Hinge axes must be signed coordinate axes of the body frame, all different.
    const mjtNum* axis = m->jnt_axis + 3 * jnt;
    int k = static_cast<int>(
        std::max_element(axis, axis + 3,
                         [](double a, double b) { return std::abs(a) < std::abs(b); }) -
        axis);
    if (std::abs(std::abs(axis[k]) - 1) > 1e-9 || used[k]) {
      ThrowConfigError(path, where + ": axes must be distinct coordinate axes (e.g. \"0 1 0\")");
    }
    used[k] = true;
    joint.axes.axis[h] = k;
    joint.axes.sign[h] = axis[k] > 0 ? 1.0 : -1.0;
    hinges->push_back(BuildHinge(m, jnt, hname ? hname : sj.name.c_str(), index, path, where));
  }
  return joint;
}

}  // namespace

std::shared_ptr<const Character> Character::Load(const std::string& path, double timestep) {
  char error[1000] = "";
  mjModel* raw = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
  if (!raw) throw ConfigError(path + ": cannot load character model: " + error);
  std::shared_ptr<Character> c(new Character());
  c->model_.reset(raw);
  c->path_ = path;
  c->warnings_ = error;  // a successful load leaves compiler warnings here
  if (timestep > 0) raw->opt.timestep = timestep;
  const mjModel* m = raw;

  c->bodies_ = SkeletonBodies(m, path);
  for (const char* name : kEndEffectors) c->end_effectors_.push_back(c->BodyId(name));
  int root = c->bodies_[0];
  if (m->body_jntnum[root] != 1 || m->jnt_type[m->body_jntadr[root]] != mjJNT_FREE ||
      m->jnt_qposadr[m->body_jntadr[root]] != 0) {
    ThrowConfigError(path, "body 'root' must have a single free joint, the model's first joint");
  }
  c->total_mass_ = 0;
  for (int b : c->bodies_) c->total_mass_ += m->body_mass[b];

  for (const auto& sj : Humanoid3dJoints()) {
    const int index = static_cast<int>(c->joints_.size());
    c->joints_.push_back(BuildJoint(m, sj, c->BodyId(sj.name), index, &c->hinges_, path));
  }
  if (static_cast<int>(c->hinges_.size()) != m->nu) {
    ThrowConfigError(path, "expected one actuator per hinge (" + std::to_string(c->hinges_.size()) +
                               "), found " + std::to_string(m->nu));
  }
  // Order hinges as the actuators are declared, so action i drives actuator i.
  std::sort(c->hinges_.begin(), c->hinges_.end(),
            [](const ActuatedHinge& a, const ActuatedHinge& b) { return a.actuator < b.actuator; });
  return c;
}

int Character::BodyId(const std::string& name) const {
  int id = mj_name2id(model_.get(), mjOBJ_BODY, name.c_str());
  if (id < 0) throw ConfigError(path_ + ": missing body '" + name + "'");
  return id;
}

Pose Character::QposToPose(const double* qpos) const {
  Pose pose;
  pose.root_position = {qpos[0], qpos[1], qpos[2]};
  pose.root_rotation = {qpos[3], qpos[4], qpos[5], qpos[6]};
  for (size_t j = 0; j < joints_.size(); ++j) {
    pose.joint_rotations.push_back(JointRotation(qpos, static_cast<int>(j)));
  }
  return pose;
}

void Character::PoseToQpos(const Pose& pose, double* qpos) const {
  for (int k = 0; k < 3; ++k) qpos[k] = pose.root_position[k];
  for (int k = 0; k < 4; ++k) qpos[3 + k] = pose.root_rotation[k];
  const mjModel* m = model_.get();
  for (size_t j = 0; j < joints_.size(); ++j) {
    const CharacterJoint& joint = joints_[j];
    double* q = qpos + joint.qpos_address;
    DecomposeHinges(joint.axes, pose.joint_rotations[j], q);
    int first = m->body_jntadr[joint.body];
    for (int h = 0; h < joint.axes.count; ++h) {
      q[h] = std::clamp(q[h], m->jnt_range[2 * (first + h)], m->jnt_range[2 * (first + h) + 1]);
    }
  }
}

Quat Character::JointRotation(const double* qpos, int j) const {
  return ComposeHinges(joints_[j].axes, qpos + joints_[j].qpos_address);
}

std::string DefaultCharacterPath() {
  return std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
}

double GeomLowestPoint(const mjModel* m, const mjData* d, int g) {
  const double* p = d->geom_xpos + 3 * g;
  const double* r = d->geom_xmat + 9 * g;  // row-major: column k is the geom's k-th axis
  const double* s = m->geom_size + 3 * g;
  switch (m->geom_type[g]) {
    case mjGEOM_SPHERE:
      return p[2] - s[0];
    case mjGEOM_CAPSULE:
      return p[2] - std::abs(r[8]) * s[1] - s[0];
    case mjGEOM_BOX:  // the centre less the largest vertical reach of the corners
      return p[2] - std::abs(r[6]) * s[0] - std::abs(r[7]) * s[1] - std::abs(r[8]) * s[2];
    default:
      return p[2] - m->geom_rbound[g];
  }
}

double Character::LowestPoint(const Pose& pose, const std::vector<int>& bodies) const {
  DataPtr d = MakeData();
  PoseToQpos(pose, d->qpos);
  mj_kinematics(model_.get(), d.get());
  double lowest = INFINITY;
  for (int g = 0; g < model_->ngeom; ++g) {
    if (model_->geom_bodyid[g] == 0) continue;  // the floor and other world geometry
    if (!bodies.empty() &&
        std::find(bodies.begin(), bodies.end(), model_->geom_bodyid[g]) == bodies.end()) {
      continue;
    }
    lowest = std::min(lowest, GeomLowestPoint(model_.get(), d.get(), g));
  }
  return lowest;
}

}  // namespace ragdoll::character
