// The simulated character: a MuJoCo model of the humanoid3d skeleton, and the mapping between
// skeleton joints, MuJoCo hinges and actuators.
#pragma once

#include <mujoco/mujoco.h>

#include <memory>
#include <string>
#include <vector>

#include "character/motion_clip.h"
#include "character/rotation.h"

namespace ragdoll::character {

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// One joint of the skeleton as it is built in the model.
struct CharacterJoint {
  std::string name;
  int body = -1;         // MuJoCo body id
  HingeAxes axes;        // its one or three hinges
  int qpos_address = 0;  // first hinge's qpos index; hinges are consecutive
  int dof_address = 0;   // first hinge's dof index
};

// One actuated hinge: the PD target the policy sets.
struct ActuatedHinge {
  std::string name;
  int joint = 0;  // index into Character::joints()
  int qpos_address = 0;
  int dof_address = 0;
  int actuator = 0;
  double lower = 0, upper = 0;  // joint range, radians
};

// Where the shipped character model lives (assets/character/humanoid.xml).
std::string DefaultCharacterPath();

// The lowest point (world z, metres) of geom `g` in the kinematics of `d`: exact for spheres,
// capsules and boxes, the bounding sphere for other shapes.
double GeomLowestPoint(const mjModel* m, const mjData* d, int g);

class Character {
 public:
  // Loads and checks an MJCF file: a free-jointed body "root", every humanoid3d joint built as
  // the matching hinges (see assets/character/humanoid.xml), a position actuator on every hinge.
  // Throws ragdoll::ConfigError naming the file and the first problem. MuJoCo compiler warnings
  // are kept in warnings(). A positive `timestep` replaces the file's physics timestep (the
  // environment derives it from its control frequency and substeps).
  static std::shared_ptr<const Character> Load(const std::string& path, double timestep = 0);

  const mjModel* model() const { return model_.get(); }
  const std::string& path() const { return path_; }
  const std::string& warnings() const { return warnings_; }
  DataPtr MakeData() const { return DataPtr(mj_makeData(model_.get())); }

  const std::vector<CharacterJoint>& joints() const { return joints_; }
  const std::vector<ActuatedHinge>& hinges() const { return hinges_; }
  // Bodies in skeleton order: root first, then the 14 others (wrists included).
  const std::vector<int>& bodies() const { return bodies_; }
  // Hands and feet, whose positions the end-effector reward compares.
  const std::vector<int>& end_effectors() const { return end_effectors_; }
  int root_body() const { return bodies_[0]; }
  double total_mass() const { return total_mass_; }
  int BodyId(const std::string& name) const;
  // The lowest point of the character's geometry (world z, metres) in a pose; of the given
  // bodies' geometry only when `bodies` is not empty.
  double LowestPoint(const Pose& pose, const std::vector<int>& bodies = {}) const;

  // Joint coordinates for a pose: root position and rotation, then each joint's rotation
  // decomposed onto its hinges and clamped to the joint's range (so a reference is always a pose
  // the character can reach). `qpos` has model()->nq entries.
  void PoseToQpos(const Pose& pose, double* qpos) const;
  // The rotation of skeleton joint j (relative to its parent) for joint coordinates `qpos`.
  Quat JointRotation(const double* qpos, int j) const;
  // The pose of joint coordinates `qpos` (the inverse of PoseToQpos for poses within range).
  Pose QposToPose(const double* qpos) const;

 private:
  Character() = default;

  ModelPtr model_;
  std::string path_;
  std::string warnings_;
  std::vector<CharacterJoint> joints_;
  std::vector<ActuatedHinge> hinges_;
  std::vector<int> bodies_;
  std::vector<int> end_effectors_;
  double total_mass_ = 0;
};

}  // namespace ragdoll::character
