// Writes the project's procedurally authored clips (AuthorClips: stand, arms, squat, walk and the
// steering motion set) as clip files.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>

#include "character/character.h"
#include "character/motion_io.h"
#include "common/config_section.h"
#include "motion/procedural_clips.h"

int main(int argc, char** argv) {
  CLI::App app(
      "Writes the project's authored motion clips (stand, arms, squat, walk, walk_backward, "
      "strafe_left, turn_left, walk_start, walk_stop).");
  std::string character_path = ragdoll::character::DefaultCharacterPath();
  std::string out_dir = std::string(RAGDOLL_ASSETS_DIR) + "/motions";
  app.add_option("--character", character_path, "character MJCF")->capture_default_str();
  app.add_option("--out", out_dir, "output folder")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    auto character = ragdoll::character::Character::Load(character_path);
    std::filesystem::create_directories(out_dir);
    for (const auto& authored : ragdoll::motion::AuthorClips(*character)) {
      std::string path = out_dir + "/" + authored.clip.name() + ".json";
      ragdoll::character::SaveClip(authored.clip, authored.description, path);
      std::cout << path << ": " << authored.clip.num_frames() << " frames, "
                << authored.clip.duration() << " s\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "ragdoll-author-clips: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
