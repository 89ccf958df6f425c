// Writing an animation in a scene format other tools read (glTF 2 binary) through Assimp's
// exporter, from the BVH the project writes (motion/retarget.h, ClipToBvh): Assimp reads that
// BVH as a skeleton of nodes with one key per frame and exports it.
#pragma once

#include <string>

namespace ragdoll::motion {

// The exporter for a file name's extension: "glb2" for .glb; empty for any other extension
// (Assimp 5.2's FBX and COLLADA writers made files nothing here read back).
std::string SceneExportFormat(const std::string& path);

// Writes `bvh_text` as `path` in the format its extension names. Throws std::runtime_error
// naming the file when Assimp cannot read the BVH or write the file.
void ExportBvhAsScene(const std::string& bvh_text, const std::string& path);

}  // namespace ragdoll::motion
