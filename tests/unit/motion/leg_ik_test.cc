#include "motion/leg_ik.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace ragdoll::motion {

using character::AngleBetween;
using character::Character;
using character::DataPtr;
using character::DefaultCharacterPath;
using character::kIdentityQuat;
using character::Normalized;
using character::Quat;
using character::Vec3;

namespace {

class LegIkTest : public ::testing::Test {
 protected:
  LegIkTest()
      : character_(Character::Load(DefaultCharacterPath())),
        m_(character_->model()),
        data_(character_->MakeData()) {}

  // The leg's seven hinges (qpos index, range), hip to ankle.
  std::vector<int> LegHinges(const std::string& side) const {
    std::vector<int> ids;
    for (const char* h :
         {"_hip_y", "_hip_x", "_hip_z", "_knee", "_ankle_y", "_ankle_x", "_ankle_z"}) {
      ids.push_back(mj_name2id(m_, mjOBJ_JOINT, (side + h).c_str()));
    }
    return ids;
  }

  // Position and rotation of `<side>_ankle` for joint coordinates `qpos`.
  void Foot(const std::vector<double>& qpos, const std::string& side, Vec3* position,
            Quat* rotation) {
    std::copy(qpos.begin(), qpos.end(), data_->qpos);
    mj_kinematics(m_, data_.get());
    int b = character_->BodyId(side + "_ankle");
    for (int k = 0; k < 3; ++k) (*position)[k] = data_->xpos[3 * b + k];
    for (int k = 0; k < 4; ++k) (*rotation)[k] = data_->xquat[4 * b + k];
  }

  // A random pose: the pelvis anywhere near standing height and turned any way, every hinge
  // uniformly within its range.
  std::vector<double> RandomPose(std::mt19937& rng) {
    std::uniform_real_distribution<double> unit(0, 1);
    std::normal_distribution<double> normal(0, 1);
    std::vector<double> qpos(m_->nq, 0.0);
    qpos[0] = 4 * unit(rng) - 2;
    qpos[1] = 4 * unit(rng) - 2;
    qpos[2] = 0.5 + unit(rng);
    Quat root = Normalized({normal(rng), normal(rng), normal(rng), normal(rng)});
    for (int k = 0; k < 4; ++k) qpos[3 + k] = root[k];
    for (int j = 1; j < m_->njnt; ++j) {
      qpos[m_->jnt_qposadr[j]] =
          m_->jnt_range[2 * j] + unit(rng) * (m_->jnt_range[2 * j + 1] - m_->jnt_range[2 * j]);
    }
    return qpos;
  }

  std::shared_ptr<const Character> character_;
  const mjModel* m_;
  DataPtr data_;
};

// Foot poses that forward kinematics produces from random within-range angles are recovered,
// starting from a straight leg (all seven hinges at zero), for any pelvis pose.
TEST_F(LegIkTest, RecoversReachableFootPoses) {
  std::mt19937 rng(7);
  DataPtr scratch = character_->MakeData();
  double worst_position = 0, worst_angle = 0;
  int most_iterations = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const std::string side = trial % 2 ? "left" : "right";
    std::vector<double> truth = RandomPose(rng);
    Vec3 position;
    Quat rotation;
    Foot(truth, side, &position, &rotation);

    std::vector<double> qpos = truth;
    for (int j : LegHinges(side)) qpos[m_->jnt_qposadr[j]] = 0;
    LegIkResult r = SolveLegIk(*character_, side, position, rotation, qpos.data(), scratch.get());

    // Checked by forward kinematics, not by the solver's own figures.
    Vec3 p;
    Quat q;
    Foot(qpos, side, &p, &q);
    double position_error = std::hypot(p[0] - position[0], p[1] - position[1], p[2] - position[2]);
    double angle_error = AngleBetween(q, rotation);
    EXPECT_LT(position_error, 1e-5) << "trial " << trial;
    EXPECT_LT(angle_error, 1e-4) << "trial " << trial;
    EXPECT_NEAR(r.position_error, position_error, 1e-9);
    EXPECT_NEAR(r.angle_error, angle_error, 1e-7);
    worst_position = std::max(worst_position, position_error);
    worst_angle = std::max(worst_angle, angle_error);
    most_iterations = std::max(most_iterations, r.iterations);
    // Only the leg changed, and it stays within its ranges.
    std::vector<int> leg = LegHinges(side);
    for (int j = 0; j < m_->njnt; ++j) {
      int a = m_->jnt_qposadr[j];
      if (std::find(leg.begin(), leg.end(), j) == leg.end()) {
        for (int k = 0; k < (j == 0 ? 7 : 1); ++k) ASSERT_EQ(qpos[a + k], truth[a + k]);
      } else {
        EXPECT_GE(qpos[a], m_->jnt_range[2 * j]);
        EXPECT_LE(qpos[a], m_->jnt_range[2 * j + 1]);
      }
    }
  }
  char figures[120];
  std::snprintf(figures, sizeof(figures), "%.2g m, %.2g rad, %d iterations at most", worst_position,
                worst_angle, most_iterations);
  RecordProperty("worst_errors", figures);
}

// A foot already at its target is left exactly as it is.
TEST_F(LegIkTest, LeavesASolvedLegUnchanged) {
  std::mt19937 rng(3);
  std::vector<double> qpos = RandomPose(rng);
  Vec3 position;
  Quat rotation;
  Foot(qpos, "right", &position, &rotation);
  std::vector<double> before = qpos;
  LegIkResult r = SolveLegIk(*character_, "right", position, rotation, qpos.data());
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(qpos, before);
}

// A foot 2 m from the hip cannot be reached: a large error, the one forward kinematics gives for
// the returned angles, and every hinge within its range.
TEST_F(LegIkTest, UnreachableTargetReportsTheErrorAndStaysWithinLimits) {
  std::vector<double> qpos(m_->nq, 0.0);
  qpos[2] = 0.9;
  qpos[3] = 1;
  const Vec3 target = {0.3, -2.0, 0.5};
  LegIkResult r = SolveLegIk(*character_, "right", target, kIdentityQuat, qpos.data());
  EXPECT_GT(r.position_error, 1.0);
  for (int j : LegHinges("right")) {
    double a = qpos[m_->jnt_qposadr[j]];
    EXPECT_GE(a, m_->jnt_range[2 * j]) << mj_id2name(m_, mjOBJ_JOINT, j);
    EXPECT_LE(a, m_->jnt_range[2 * j + 1]) << mj_id2name(m_, mjOBJ_JOINT, j);
  }
  Vec3 p;
  Quat q;
  Foot(qpos, "right", &p, &q);
  EXPECT_NEAR(std::hypot(p[0] - target[0], p[1] - target[1], p[2] - target[2]), r.position_error,
              1e-9);
}

TEST_F(LegIkTest, RejectsAnotherSide) {
  std::vector<double> qpos(m_->nq, 0.0);
  qpos[3] = 1;
  EXPECT_THROW(SolveLegIk(*character_, "middle", {0, 0, 0}, kIdentityQuat, qpos.data()),
               std::invalid_argument);
}

}  // namespace
}  // namespace ragdoll::motion
