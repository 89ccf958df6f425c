// The renderer draws what the simulation holds: run under Xvfb (see tests/CMakeLists.txt).
#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "character/character.h"
#include "character/motion_io.h"
#include "render/video.h"

namespace ragdoll::render {
namespace {

const std::string kAssets = RAGDOLL_ASSETS_DIR;

class RenderTest : public ::testing::Test {
 protected:
  RenderTest()
      : character_(character::Character::Load(kAssets + "/character/humanoid.xml")),
        data_(character_->MakeData()),
        reference_(character_->MakeData()) {
    character::MotionClip walk = character::LoadMotion(kAssets + "/motions/walk.json");
    character_->PoseToQpos(walk.Sample(0.3), data_->qpos);
    mj_kinematics(character_->model(), data_.get());
    character_->PoseToQpos(walk.Sample(0.6), reference_->qpos);
    mj_kinematics(character_->model(), reference_.get());
  }
  const double* GeomCentre(const std::string& name) {
    int g = mj_name2id(character_->model(), mjOBJ_GEOM, name.c_str());
    EXPECT_GE(g, 0) << name;
    return data_->geom_xpos + 3 * g;
  }
  int GeomId(const std::string& name) {
    return mj_name2id(character_->model(), mjOBJ_GEOM, name.c_str());
  }

  std::shared_ptr<const character::Character> character_;
  character::DataPtr data_, reference_;
};

TEST_F(RenderTest, DrawsAFrameThatIsNotBlank) {
  View view;
  view.width = 320;
  view.height = 240;
  Renderer r(character_->model(), view);
  r.Draw(*data_, nullptr, "test");
  const auto& p = r.pixels();
  ASSERT_EQ(p.size(), 320u * 240 * 3);
  double mean = 0, var = 0;
  std::set<int> colours;
  for (size_t i = 0; i < p.size(); i += 3) {
    const double v = (p[i] + p[i + 1] + p[i + 2]) / 3.0;
    mean += v;
    var += v * v;
    colours.insert(p[i] << 16 | p[i + 1] << 8 | p[i + 2]);
  }
  const double n = p.size() / 3.0;
  mean /= n;
  const double stddev = std::sqrt(var / n - mean * mean);
  EXPECT_GT(stddev, 10) << "a flat image";
  EXPECT_GT(colours.size(), 200u);
}

// Each body part appears on screen where the simulation puts it: the geom drawn at the pixel a
// geom's centre projects to is that geom.
TEST_F(RenderTest, TheCharacterIsWhereTheSimulationSays) {
  // Standing, seen from the front: no part hides another's centre.
  character::MotionClip stand = character::LoadMotion(kAssets + "/motions/stand.json");
  character_->PoseToQpos(stand.Sample(0), data_->qpos);
  data_->qpos[0] += 0.7;  // away from the origin, so a drawing at the origin would show
  mj_kinematics(character_->model(), data_.get());
  View view;
  view.width = 640;
  view.height = 480;
  view.azimuth = 180;  // looking along -x, at the character's front
  view.elevation = -5;
  Renderer r(character_->model(), view);
  r.Draw(*data_, nullptr, "");
  for (const char* geom : {"root", "chest", "neck", "right_knee", "left_knee", "left_ankle",
                           "right_elbow", "left_wrist"}) {
    ASSERT_GE(GeomId(geom), 0) << geom;
    double x, y;
    ASSERT_TRUE(r.Project(GeomCentre(geom), &x, &y)) << geom;
    ASSERT_GE(x, 0);
    ASSERT_LT(x, view.width);
    ASSERT_GE(y, 0);
    ASSERT_LT(y, view.height);
    const int at = r.GeomAt(static_cast<int>(x), static_cast<int>(y));
    std::string name = at >= 0 ? mj_id2name(character_->model(), mjOBJ_GEOM, at) : "(none)";
    EXPECT_EQ(name, geom) << "at pixel " << x << ", " << y;
  }
  // Far to the side of the character there is no character.
  double x, y;
  const double* root = GeomCentre("root");
  const double aside[3] = {root[0] + 3, root[1], root[2]};
  if (r.Project(aside, &x, &y) && x >= 0 && x < view.width && y >= 0 && y < view.height) {
    const int at = r.GeomAt(static_cast<int>(x), static_cast<int>(y));
    EXPECT_TRUE(at < 0 || character_->model()->geom_bodyid[at] == 0);
  }
}

TEST_F(RenderTest, TheGhostIsDrawnBesideAndIsNotTheCharacter) {
  View view;
  view.width = 640;
  view.height = 480;
  view.azimuth = 135;
  view.ghost_offset = 1.0;
  Renderer r(character_->model(), view);
  r.Draw(*data_, reference_.get(), "");
  const int g = GeomId("root");
  double ghost_root[3];
  for (int i = 0; i < 3; ++i) ghost_root[i] = reference_->geom_xpos[3 * g + i];
  ghost_root[1] += 1.0;
  double x, y;
  ASSERT_TRUE(r.Project(ghost_root, &x, &y));
  // The ghost's pelvis pixel is bluish (the ghost tint) and not a character geom.
  const auto& p = r.pixels();
  const size_t i = (static_cast<size_t>(y) * view.width + static_cast<size_t>(x)) * 3;
  EXPECT_GT(p[i + 2], p[i]) << "not tinted blue";
  const int at = r.GeomAt(static_cast<int>(x), static_cast<int>(y));
  EXPECT_TRUE(at < 0 || character_->model()->geom_bodyid[at] == 0);
}

TEST_F(RenderTest, WritesPngAndMp4ThroughFfmpeg) {
  View view;
  view.width = 160;
  view.height = 120;
  Renderer r(character_->model(), view);
  const std::string dir = ::testing::TempDir();
  {
    VideoWriter png(dir + "/frame.png", view.width, view.height, 30);
    r.Draw(*data_, nullptr, "");
    png.Write(r.pixels());
    png.Write(r.pixels());  // ignored: a still has one frame
    png.Close();
    EXPECT_EQ(png.frames(), 1);
  }
  std::ifstream in(dir + "/frame.png", std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  VideoWriter mp4(dir + "/clip.mp4", view.width, view.height, 30);
  for (int f = 0; f < 10; ++f) {
    r.Draw(f % 2 ? *data_ : *reference_, nullptr, "");
    mp4.Write(r.pixels());
  }
  mp4.Close();
  EXPECT_GT(std::filesystem::file_size(dir + "/clip.mp4"), 1000u);
  EXPECT_THROW(VideoWriter(dir + "/clip.avi", 16, 16, 30), std::runtime_error);
}

}  // namespace
}  // namespace ragdoll::render
