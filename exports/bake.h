// A trained policy's simulated performance baked into an animation of the character's skeleton
// (BVH, FBX, glTF binary, or the project's clip format), for animators and engines without a
// physics runtime: the policy runs one episode in its own environment and every control step's
// pose becomes a frame.
#pragma once

#include <cstdint>
#include <string>

namespace ragdoll::exports {

struct BakeOptions {
  std::string target;  // run folder or checkpoint
  // The file to write; its extension chooses the format: .bvh, .fbx (converted by Blender), .glb
  // (by Assimp), or .json (the project's clip format, as `motion import` writes it).
  std::string out;
  std::string naming = "ragdoll";  // bone names: a mapping preset (ragdoll, mixamo, cmu) or YAML
  std::string commands;            // steering runs: a command script; empty: the first command
  std::string units;               // "m" or "cm"; empty: m
  std::string up = "y";            // "y" or "z"
  double seconds = 0;              // 0: a one-shot clip's length, 10 s otherwise
  double fps = 0;                  // 0: the control rate
  double phase = 0;                // the clip's phase to start from, 0..1
  uint64_t seed = 1;               // the episode's seed, and the push directions'
  double pushes = 0;               // N s on the pelvis, 0: none
  double push_every = 2;           // s
};

// Simulates `options.target`'s policy and writes what it did to `options.out`. The episode is kept
// going for the whole length (no time limit, and with pushes no distance limit): only a fall ends
// it early. Reports each push and the file written on stderr ("bake: ..." lines). Throws
// ConfigError for an output format it does not write (COLLADA, unknown extensions), a command
// script for a run without a steering task, or Blender missing for .fbx; std::runtime_error when
// a file cannot be written or Blender fails.
void Bake(const BakeOptions& options);

}  // namespace ragdoll::exports
