#include "character/character.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>

#include "character/skeleton.h"

namespace ragdoll::character {
namespace {

const std::string kCharacter = std::string(RAGDOLL_ASSETS_DIR) + "/character/humanoid.xml";
constexpr double kDeg = M_PI / 180;

// Turns MuJoCo warnings printed while the fixture lives into test failures.
class CharacterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    warnings().clear();
    mju_user_warning = [](const char* message) { warnings() += message; };
    character_ = Character::Load(kCharacter);
  }
  void TearDown() override {
    mju_user_warning = nullptr;
    EXPECT_EQ(warnings(), "");
  }
  static std::string& warnings() {
    static std::string w;
    return w;
  }
  std::shared_ptr<const Character> character_;
};

TEST_F(CharacterTest, LoadsWithoutWarnings) {
  EXPECT_EQ(character_->warnings(), "");
  DataPtr d = character_->MakeData();
  mj_forward(character_->model(), d.get());
  for (int w = 0; w < mjNWARNING; ++w) EXPECT_EQ(d->warning[w].number, 0) << "warning " << w;
}

TEST_F(CharacterTest, SegmentMassesFollowDeLeva) {
  // de Leva (1996), mean of male and female, % of body mass; the trunk's 43.02 % is split into
  // the lower trunk (pelvis, 11.82 %) and the rest (chest, 31.20 %).
  const std::map<std::string, double> percent = {
      {"root", 11.82},          {"chest", 31.20},        {"neck", 6.81},
      {"right_shoulder", 2.63}, {"left_shoulder", 2.63}, {"right_elbow", 1.50},
      {"left_elbow", 1.50},     {"right_wrist", 0.585},  {"left_wrist", 0.585},
      {"right_hip", 14.47},     {"left_hip", 14.47},     {"right_knee", 4.57},
      {"left_knee", 4.57},      {"right_ankle", 1.33},   {"left_ankle", 1.33}};
  const mjModel* m = character_->model();
  EXPECT_NEAR(character_->total_mass(), 60.0, 1e-9);
  EXPECT_NEAR(mj_getTotalmass(m), 60.0, 1e-9);
  double sum = 0;
  for (const auto& [body, p] : percent) {
    double mass = m->body_mass[character_->BodyId(body)];
    EXPECT_NEAR(100 * mass / 60.0, p, 0.01) << body;
    sum += p;
  }
  EXPECT_NEAR(sum, 100.0, 0.01);
}

TEST_F(CharacterTest, HasTheHumanoid3dSkeleton) {
  const auto& joints = character_->joints();
  ASSERT_EQ(joints.size(), Humanoid3dJoints().size());
  for (size_t j = 0; j < joints.size(); ++j) {
    EXPECT_EQ(joints[j].name, Humanoid3dJoints()[j].name);
    EXPECT_EQ(joints[j].axes.count, Humanoid3dJoints()[j].type == JointType::kSpherical ? 3 : 1);
  }
  EXPECT_EQ(character_->bodies().size(), 15u);  // humanoid3d's 15 links, wrists included
  EXPECT_EQ(character_->hinges().size(), 28u);  // 8 spherical x 3 + 4 revolute
  EXPECT_EQ(character_->model()->nu, 28);
  EXPECT_EQ(character_->model()->nv, 6 + 28);
  for (size_t i = 0; i < character_->hinges().size(); ++i) {
    EXPECT_EQ(character_->hinges()[i].actuator, static_cast<int>(i));
  }
}

TEST_F(CharacterTest, JointLimitsAreHuman) {
  auto range = [this](const std::string& hinge) {
    for (const auto& h : character_->hinges()) {
      if (h.name == hinge) return std::make_pair(h.lower / kDeg, h.upper / kDeg);
    }
    ADD_FAILURE() << "no hinge " << hinge;
    return std::make_pair(0.0, 0.0);
  };
  // Knees and elbows bend one way only, up to 150 degrees.
  for (const char* h : {"right_knee", "left_knee", "right_elbow", "left_elbow"}) {
    EXPECT_NEAR(range(h).first, 0, 1e-9) << h;
    EXPECT_NEAR(range(h).second, 150, 1e-9) << h;
  }
  // Hip flexion (-y) to 120 degrees, extension to 30.
  EXPECT_NEAR(range("right_hip_y").first, -120, 1e-9);
  EXPECT_NEAR(range("right_hip_y").second, 30, 1e-9);
  // Abduction is mirrored between the sides: the right leg abducts towards -y.
  EXPECT_NEAR(range("right_hip_x").first, -45, 1e-9);
  EXPECT_NEAR(range("left_hip_x").second, 45, 1e-9);
  EXPECT_NEAR(range("right_shoulder_x").first, -170, 1e-9);
  EXPECT_NEAR(range("left_shoulder_x").second, 170, 1e-9);
  // Every range holds the rest pose, and sides mirror each other.
  for (const auto& h : character_->hinges()) {
    EXPECT_LE(h.lower, 0) << h.name;
    EXPECT_GE(h.upper, 0) << h.name;
    if (h.name.rfind("right_", 0) == 0) {
      auto left = range("left_" + h.name.substr(6));
      bool mirrored = h.name.back() == 'x' || h.name.back() == 'z';
      if (h.name.back() == 'x') {  // abduction flips sign
        EXPECT_NEAR(left.first, -h.upper / kDeg, 1e-9) << h.name;
        EXPECT_NEAR(left.second, -h.lower / kDeg, 1e-9) << h.name;
      } else if (!mirrored || h.name.back() == 'z') {
        EXPECT_NEAR(left.first, h.lower / kDeg, 1e-9) << h.name;
        EXPECT_NEAR(left.second, h.upper / kDeg, 1e-9) << h.name;
      }
    }
  }
}

TEST_F(CharacterTest, DefaultPoseRestsOnTheFloor) {
  const mjModel* m = character_->model();
  DataPtr d = character_->MakeData();
  mj_forward(m, d.get());
  int right = mj_name2id(m, mjOBJ_GEOM, "right_ankle");
  int left = mj_name2id(m, mjOBJ_GEOM, "left_ankle");
  // Soles exactly on the floor in the model's default pose.
  EXPECT_NEAR(GeomLowestPoint(m, d.get(), right), 0.0, 1e-4);
  EXPECT_NEAR(GeomLowestPoint(m, d.get(), left), 0.0, 1e-4);

  // Held by its PD drives at the rest pose, it settles without sinking, and only feet touch.
  double start_height = d->qpos[2];
  for (int i = 0; i < 300; ++i) mj_step(m, d.get());  // 0.5 s
  EXPECT_NEAR(d->qpos[2], start_height, 0.01);
  EXPECT_GT(GeomLowestPoint(m, d.get(), right), -0.005);
  EXPECT_GT(d->ncon, 0);
  for (int c = 0; c < d->ncon; ++c) {
    int b1 = m->geom_bodyid[d->contact[c].geom1], b2 = m->geom_bodyid[d->contact[c].geom2];
    int body = b1 == 0 ? b2 : b1;
    std::string name = mj_id2name(m, mjOBJ_BODY, body);
    EXPECT_TRUE(name == "right_ankle" || name == "left_ankle") << name << " touches the floor";
  }
}

TEST_F(CharacterTest, PoseToQposRoundTripsJointRotations) {
  const mjModel* m = character_->model();
  Pose pose;
  pose.root_position = {0.1, -0.2, 0.9};
  pose.root_rotation = AxisAngle({0, 0, 1}, 0.4);
  std::vector<double> angles = {0.2, -0.1, 0.3};
  for (const auto& joint : character_->joints()) {
    pose.joint_rotations.push_back(ComposeHinges(joint.axes, angles.data()));
  }
  std::vector<double> qpos(m->nq);
  character_->PoseToQpos(pose, qpos.data());
  EXPECT_DOUBLE_EQ(qpos[0], 0.1);
  EXPECT_DOUBLE_EQ(qpos[2], 0.9);
  for (size_t j = 0; j < character_->joints().size(); ++j) {
    const auto& joint = character_->joints()[j];
    for (int h = 0; h < joint.axes.count; ++h) {
      EXPECT_NEAR(qpos[joint.qpos_address + h], angles[h], 1e-12) << joint.name;
    }
    EXPECT_NEAR(AngleBetween(character_->JointRotation(qpos.data(), static_cast<int>(j)),
                             pose.joint_rotations[j]),
                0, 1e-9);
  }
  // Out-of-range rotations are clamped to the joint's range: a knee cannot hyper-extend.
  pose.joint_rotations[3] = AxisAngle({0, 1, 0}, -0.5);
  character_->PoseToQpos(pose, qpos.data());
  EXPECT_EQ(qpos[character_->joints()[3].qpos_address], 0.0);
}

TEST(CharacterLoad, RejectsBadFilesNamingThem) {
  try {
    Character::Load("/nonexistent/model.xml");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/model.xml"), std::string::npos);
  }
  // A model without the humanoid3d skeleton.
  try {
    Character::Load("/usr/share/mujoco/model/humanoid/humanoid.xml");
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("missing body 'root'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ragdoll::character
