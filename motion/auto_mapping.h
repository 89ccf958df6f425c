// `--map auto`: which joint of an imported skeleton drives each part of the character, found from
// the joints' names and the hierarchy, for the namings users meet: Mixamo (with or without its
// "mixamorig:" namespace), both common namings of the CMU database's BVH files, Unreal's and
// Unity's humanoid rigs, LAFAN1, Blender's Rigify/metarig, 3ds Max Biped, and the project's own.
//
// Names are split into words (camel case, separators, Biped's "L"/"R", Rigify's ".L"), the side
// and the body-part word are read from them, and each part takes the best-ranked synonym that
// also fits the hierarchy (a knee below its hip, an elbow below its shoulder). The chest is where
// the two arms meet; the root where the legs meet when no joint is called hips or pelvis. When
// names do not say left or right, the rest pose decides (left of the facing direction, which the
// toes give).
#pragma once

#include <string>
#include <vector>

#include "motion/retarget.h"
#include "motion/skeleton_animation.h"

namespace ragdoll::motion {

struct AutoMapping {
  JointMapping mapping;            // origin "auto (<scheme>)"
  std::string scheme;              // the naming recognised, e.g. "Mixamo", or "unrecognised"
  std::vector<std::string> notes;  // decisions worth printing (geometry used for sides, ...)
};

// Throws ConfigError naming the file, the parts that could not be mapped and, for each, the
// joints whose names come nearest.
AutoMapping MapAutomatically(const SkeletonAnimation& skeleton);

// The mapping for `preset_or_path`: "auto", a preset name or a YAML file (ReadJointMapping).
// `notes` (optional) receives what was chosen, one line per decision, for the user to read.
JointMapping ResolveMapping(const std::string& preset_or_path, const SkeletonAnimation& skeleton,
                            std::vector<std::string>* notes = nullptr);

// Lower-case words of a joint name without namespace: "mixamorig:LeftUpLeg" -> left up leg,
// "Bip01 L Thigh" -> bip01 l thigh, "thigh.L" -> thigh l, "LHipJoint" -> l hip joint.
std::vector<std::string> NameWords(const std::string& name);

}  // namespace ragdoll::motion
