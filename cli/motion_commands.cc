#include "cli/motion_commands.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "character/motion_io.h"
#include "motion/auto_mapping.h"
#include "motion/bvh.h"
#include "motion/clip_kind.h"
#include "motion/clip_report.h"
#include "motion/foot_cleanup.h"
#include "motion/retarget.h"
#include "motion/root_motion.h"
#include "motion/scene_import.h"

namespace ragdoll::cli {
namespace {

struct MotionOptions {
  std::string input, output, mapping = "auto", animation, feet = "floor", bvh_reader = "ragdoll",
                             naming = "ragdoll", order = "ZXY", units = "m", up = "y", character,
                             json, root_motion = "auto";
  motion::ImportOptions import;
  bool inspect_after = true;
  int fix_feet = -1;  // -1: when the clip needs it; 0: never (--no-fix-feet); 1: always
};

std::string CharacterPath(const std::string& given) {
  return given.empty() ? character::DefaultCharacterPath() : given;
}

// The import's work, without its output: the clip, the lines it prints, and its timings.
struct ImportResult {
  character::MotionClip clip;
  std::vector<std::string> notes;
  std::string description;  // "imported from FILE with mapping M"
  std::string summary;      // the source and the clip, one line
};

ImportResult ImportWith(const MotionOptions& o, const std::string& output) {
  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  std::vector<std::string> notes;
  motion::SkeletonAnimation source = motion::LoadSkeletonAnimation(
      o.input, o.animation, &notes,
      o.bvh_reader == "assimp" ? motion::BvhReader::kAssimp : motion::BvhReader::kRagdoll);
  auto t1 = Clock::now();
  auto character = character::Character::Load(CharacterPath(o.character));
  motion::JointMapping mapping = motion::ResolveMapping(o.mapping, source, &notes);
  motion::ImportOptions options = o.import;
  options.feet =
      o.feet == "rest" ? motion::ImportOptions::Feet::kRest : motion::ImportOptions::Feet::kFloor;
  character::MotionClip clip = motion::Retarget(source, mapping, *character, options, &notes);
  motion::RootMotionReport root;
  clip = motion::ReconstructRootMotion(clip, *character, motion::ParseRootMotion(o.root_motion),
                                       &root);
  if (o.root_motion != "keep") notes.push_back(root.Summary());
  if (o.fix_feet != 0) {
    motion::FootCleanupReport fixed;
    character::MotionClip cleaned =
        motion::FixFeet(clip, *character, motion::FootCleanupOptions{}, &fixed);
    char line[480];
    if (o.fix_feet == 1 || fixed.Needed()) {
      clip = std::move(cleaned);
      std::snprintf(line, sizeof(line),
                    "feet cleaned up%s: %d right and %d left plants (%.0f %% / %.0f %% of frames) "
                    "put on the floor and held still; the feet were %.1f / %.1f cm above it at "
                    "their lowest; largest ankle move %.1f cm, pelvis lowered up to %.1f cm%s",
                    o.fix_feet == 1 ? " (--fix-feet)" : "", fixed.plants[0], fixed.plants[1],
                    100 * fixed.planted_fraction[0], 100 * fixed.planted_fraction[1],
                    100 * fixed.float_height[0], 100 * fixed.float_height[1],
                    100 * fixed.max_correction, 100 * fixed.max_drop,
                    o.fix_feet == 1 ? "" : " (--no-fix-feet: as they came)");
      notes.push_back(line);
      if (fixed.missed_frames > 0) {
        std::snprintf(line, sizeof(line),
                      "feet: warning: in %d frames a leg cannot reach its planted foot (up to "
                      "%.1f cm short: the foot is beyond the ankle's range)",
                      fixed.missed_frames, 100 * fixed.max_miss);
        notes.push_back(line);
      }
    } else {
      std::snprintf(line, sizeof(line),
                    "feet: left as they came: planted feet already on the floor and still (a "
                    "clean-up would move an ankle %.1f cm at most)",
                    100 * fixed.max_correction);
      notes.push_back(line);
    }
  }
  auto t2 = Clock::now();
  char line[400];
  std::snprintf(line, sizeof line,
                "%s (%s): %d frames at %.1f frames/s, %zu joints -> %s: %d frames, %.3f s "
                "(read %.0f ms, retarget %.0f ms)",
                o.input.c_str(), source.format.c_str(), source.num_frames(), 1 / source.frame_time,
                source.joints.size(), output.c_str(), clip.num_frames(), clip.duration(),
                std::chrono::duration<double, std::milli>(t1 - t0).count(),
                std::chrono::duration<double, std::milli>(t2 - t1).count());
  return {std::move(clip), std::move(notes),
          "imported from " + std::filesystem::path(o.input).filename().string() + " with mapping " +
              mapping.origin,
          line};
}

int Import(const MotionOptions& o) {
  ImportResult r = ImportWith(o, o.output);
  for (const auto& n : r.notes) std::fprintf(stderr, "%s\n", n.c_str());
  if (!r.clip.loop() && motion::ClosesALoop(r.clip)) {
    std::fprintf(
        stderr, "loop: the last frame is the first pose again: --loop marks the clip as a cycle\n");
  }
  character::SaveClip(r.clip, r.description, o.output);
  std::fprintf(stderr, "%s\n", r.summary.c_str());
  if (o.inspect_after) {
    auto character = character::Character::Load(CharacterPath(o.character));
    std::cout << motion::InspectClip(r.clip, *character).ToText();
  }
  std::fprintf(stderr, "train it: ragdoll train --motion %s\n", o.output.c_str());
  return 0;
}

int Export(const MotionOptions& o) {
  auto character = character::Character::Load(CharacterPath(o.character));
  character::MotionClip clip = character::LoadMotion(o.input);
  motion::ExportOptions e;
  e.rotation_order = o.order;
  e.units_per_metre = o.units == "cm" ? 100 : 1;
  e.y_up = o.up == "y";
  std::string text =
      motion::FormatBvh(motion::ClipToBvh(clip, *character, motion::ReadJointMapping(o.naming), e));
  std::ofstream out(o.output);
  out << text;
  if (!out) throw std::runtime_error(o.output + ": cannot write");
  std::fprintf(stderr, "%s: %d frames -> %s (%s-up, %s, %s order, %s names)\n", o.input.c_str(),
               clip.num_frames(), o.output.c_str(), o.up.c_str(), o.units.c_str(), o.order.c_str(),
               o.naming.c_str());
  return 0;
}

int Inspect(const MotionOptions& o) {
  auto character = character::Character::Load(CharacterPath(o.character));
  character::MotionClip clip = character::LoadMotion(o.input);
  motion::ClipReport report = motion::InspectClip(clip, *character);
  std::cout << report.ToText();
  if (!o.json.empty()) std::ofstream(o.json) << report.ToJson() << "\n";
  return 0;
}

// `motion import FILE --out CLIP`: which file and animation, how its joints map onto the
// character, and which frames become the clip.
CLI::App* AddImport(CLI::App* motion, const std::shared_ptr<MotionOptions>& o) {
  auto* import = motion->add_subcommand(
      "import", "retarget a BVH, FBX, glTF/GLB or COLLADA animation onto the character");
  import->add_option("file", o->input, "motion file (.bvh, .fbx, .gltf, .glb, .dae)")
      ->required()
      ->check(CLI::ExistingFile);
  import
      ->add_option("--map", o->mapping,
                   "joint mapping: auto (from the joint names), a preset (cmu, mixamo, "
                   "ragdoll) or a YAML file")
      ->capture_default_str();
  import->add_option("--animation", o->animation,
                     "which animation of a file that holds several: its name or index");
  import
      ->add_option("--feet", o->feet,
                   "floor: level each foot on the frames it is planted; rest: align it from "
                   "the rest pose like the other joints")
      ->check(CLI::IsMember({"floor", "rest"}))
      ->capture_default_str();
  import
      ->add_option("--bvh-reader", o->bvh_reader,
                   "read BVH files with ragdoll's parser or Assimp's")
      ->check(CLI::IsMember({"ragdoll", "assimp"}))
      ->capture_default_str();
  import->add_option("--out", o->output, "clip to write (.json)")->required();
  import->add_option("--name", o->import.name, "clip name (default: the file's stem)");
  import->add_option("--first", o->import.first_frame, "first frame to use")
      ->check(CLI::NonNegativeNumber);
  import->add_option("--last", o->import.last_frame, "last frame to use (default: the last)");
  import->add_option("--fps", o->import.fps, "resample to this frame rate")
      ->check(CLI::PositiveNumber);
  return import;
}

// `motion import`'s clean-ups and adjustments of the retargeted clip: feet, root motion, mirror,
// loop, scale, and the character it lands on.
void AddImportAdjustments(CLI::App* import, const std::shared_ptr<MotionOptions>& o) {
  auto always = [o] { o->fix_feet = 1; };
  auto never = [o] { o->fix_feet = 0; };
  auto* fix = import->add_flag_callback(
      "--fix-feet", always,
      "clean up the feet even where the clip does not need it (by default the import does when "
      "planted feet float, sink or slide on the character): solve the legs so that planted feet "
      "stand on the floor and hold still, the pelvis lowered where a leg cannot reach");
  import->add_flag_callback("--no-fix-feet", never, "keep the feet as the retarget leaves them")
      ->excludes(fix);
  import
      ->add_option("--root-motion", o->root_motion,
                   "auto: rebuild the root's travel from the planted feet when the clip was "
                   "exported in place (feet sliding under a root that stays put); feet: always; "
                   "keep: never")
      ->check(CLI::IsMember({"auto", "feet", "keep"}))
      ->capture_default_str();
  import->add_flag("--mirror", o->import.mirror, "swap left and right");
  import->add_flag("--loop", o->import.loop, "mark the clip as looping");
  import
      ->add_option("--scale", o->import.scale, "metres per BVH unit (default: from the leg length)")
      ->check(CLI::PositiveNumber);
  import->add_option("--character", o->character, "character MJCF (default: the shipped one)");
}

// `motion export CLIP --out FILE.bvh`: the BVH's joint names, channel order, units and up axis.
CLI::App* AddExport(CLI::App* motion, const std::shared_ptr<MotionOptions>& o) {
  auto* exporter = motion->add_subcommand("export", "write a clip as BVH (for Blender, Maya...)");
  exporter->add_option("clip", o->input, "clip (.json or DeepMimic .txt)")
      ->required()
      ->check(CLI::ExistingFile);
  exporter->add_option("--out", o->output, "BVH file to write")->required();
  exporter->add_option("--naming", o->naming, "joint names: a mapping preset or YAML file")
      ->capture_default_str();
  exporter->add_option("--order", o->order, "rotation channel order")->capture_default_str();
  exporter->add_option("--units", o->units, "m or cm")
      ->check(CLI::IsMember({"m", "cm"}))
      ->capture_default_str();
  exporter->add_option("--up", o->up, "y or z")
      ->check(CLI::IsMember({"y", "z"}))
      ->capture_default_str();
  exporter->add_option("--character", o->character, "character MJCF (default: the shipped one)");
  return exporter;
}

// `motion inspect CLIP [--json FILE]`.
CLI::App* AddInspect(CLI::App* motion, const std::shared_ptr<MotionOptions>& o) {
  auto* inspect = motion->add_subcommand("inspect", "timing, travel, foot contact, problems");
  inspect->add_option("clip", o->input, "clip (.json or DeepMimic .txt)")
      ->required()
      ->check(CLI::ExistingFile);
  inspect->add_option("--json", o->json, "also write the report as JSON");
  inspect->add_option("--character", o->character, "character MJCF (default: the shipped one)");
  return inspect;
}

}  // namespace

ImportedMotion ImportMotionFile(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".json" || ext == ".txt") {
    character::MotionClip clip = character::LoadMotion(path);
    return {clip, {}, "the clip " + std::filesystem::path(path).filename().string()};
  }
  MotionOptions o;
  o.input = path;
  ImportResult r = ImportWith(o, "the run folder");
  r.notes.push_back(r.summary);
  std::string why;
  if (motion::ClosesALoop(r.clip, &why)) {
    r.clip = motion::AsLoop(r.clip);
    r.notes.push_back("loop: yes, " + why);
  } else {
    r.notes.push_back("loop: no, " + why);
  }
  return {std::move(r.clip), std::move(r.notes), r.description};
}

std::function<int()> AddMotionCommands(CLI::App& app) {
  auto o = std::make_shared<MotionOptions>();
  auto* motion = app.add_subcommand("motion", "import, export and inspect motion clips");
  motion->require_subcommand(1);
  auto* import = AddImport(motion, o);
  AddImportAdjustments(import, o);
  auto* exporter = AddExport(motion, o);
  AddInspect(motion, o);
  return [=]() -> int {
    if (!*motion) return -1;
    if (*import) return Import(*o);
    if (*exporter) return Export(*o);
    return Inspect(*o);
  };
}

}  // namespace ragdoll::cli
