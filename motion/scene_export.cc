#include "motion/scene_export.h"

#include <assimp/scene.h>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>

#include <filesystem>
#include <stdexcept>

namespace ragdoll::motion {

std::string SceneExportFormat(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // Assimp 5.2's FBX and COLLADA writers are left out: the FBX files they wrote here were read
  // back by neither Blender 3.4 nor Assimp ("nested block sentinel"), and the COLLADA files lost
  // their animation (docs/motion-import.md, "Bake").
  if (ext == ".glb") return "glb2";
  return "";
}

void ExportBvhAsScene(const std::string& bvh_text, const std::string& path) {
  const std::string format = SceneExportFormat(path);
  if (format.empty()) {
    throw std::runtime_error(path + ": not a scene format written here (.glb)");
  }
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFileFromMemory(bvh_text.data(), bvh_text.size(), 0, "bvh");
  if (scene == nullptr) {
    throw std::runtime_error(path + ": Assimp could not read the BVH it was to convert (" +
                             importer.GetErrorString() + ")");
  }
  Assimp::Exporter exporter;
  if (exporter.Export(scene, format, path) != AI_SUCCESS) {
    throw std::runtime_error(path + ": Assimp's " + format + " exporter failed (" +
                             exporter.GetErrorString() + ")");
  }
}

}  // namespace ragdoll::motion
