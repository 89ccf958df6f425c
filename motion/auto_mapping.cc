#include "motion/auto_mapping.h"

#include <algorithm>
#include <cctype>
#include <functional>
#include <map>
#include <set>

#include "character/vector.h"
#include "common/config_section.h"

namespace ragdoll::motion {

using character::Cross;
using character::Dot;
using character::Sub;
using character::Vec3;

namespace {

enum Side { kNoSide = -1, kRight = 0, kLeft = 1 };

// What a joint's name says: its side and the body-part word (the words without side, joined,
// digits without leading zeros: "spine_01" -> "spine1").
struct Name {
  int joint = -1;
  Side side = kNoSide;
  std::string base;
};

// Synonyms of each part's word, best first. A joint matches when its base equals one of them,
// or, ranked after every exact match, does so without trailing digits ("thigh.001", "Neck1").
// Where a rig has both, the joint named for the joint wins over the one named for the bone
// beyond it (CMU's ASF names: lwrist before lhand).
const std::map<std::string, std::vector<std::string>>& Synonyms() {
  static const std::map<std::string, std::vector<std::string>> kSynonyms = {
      {"root", {"hips", "pelvis", "hip", "root"}},
      {"hip", {"upleg", "upperleg", "thigh", "femur", "hip"}},
      {"knee", {"leg", "lowerleg", "calf", "shin", "knee", "tibia", "lowleg"}},
      {"ankle", {"ankle", "foot"}},
      {"toe", {"toebase", "toe", "toes", "ball", "toe0"}},
      {"shoulder", {"arm", "upperarm", "uparm", "humerus", "shoulder"}},
      {"elbow", {"forearm", "lowerarm", "elbow", "radius", "lowarm"}},
      {"wrist", {"wrist", "hand"}},
      {"neck", {"neck", "lowerneck", "neck1", "neck0"}},
      {"head", {"head"}},
  };
  return kSynonyms;
}

// Words that say nothing about the body part: rig prefixes.
bool IsRigWord(const std::string& w) {
  static const std::set<std::string> kWords = {"bip", "def",  "org",      "mch", "j",         "jnt",
                                               "bn",  "bone", "armature", "rig", "mixamorig", "b"};
  if (kWords.count(w)) return true;
  // bip01, bip001, character1, mixamorig1
  for (const char* prefix : {"bip", "character", "mixamorig"}) {
    const std::string p = prefix;
    if (w.size() > p.size() && w.compare(0, p.size(), p) == 0 &&
        std::all_of(w.begin() + p.size(), w.end(), [](char c) { return std::isdigit(c); })) {
      return true;
    }
  }
  return false;
}

Side SideOf(const std::string& w) {
  if (w == "left" || w == "l" || w == "lft") return kLeft;
  if (w == "right" || w == "r" || w == "rt" || w == "rgt") return kRight;
  return kNoSide;
}

// Digits without leading zeros: "spine01" -> "spine1", "thigh001" -> "thigh1", "toe0" stays.
std::string StripLeadingZeros(const std::string& s) {
  std::string out;
  bool leading = false;
  for (size_t i = 0; i < s.size(); ++i) {
    const bool digit = std::isdigit(static_cast<unsigned char>(s[i]));
    if (digit && (i == 0 || !std::isdigit(static_cast<unsigned char>(s[i - 1])))) leading = true;
    if (!digit) leading = false;
    const bool more = i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1]));
    if (leading && s[i] == '0' && more) continue;
    leading = false;
    out += s[i];
  }
  return out;
}

bool KnownWord(const std::string& base) {
  for (const auto& [part, words] : Synonyms()) {
    if (std::find(words.begin(), words.end(), base) != words.end()) return true;
  }
  return base == "clavicle" || base == "collar" || base == "hipjoint" || base == "toes";
}

Name Parse(int joint, const std::string& full) {
  Name name;
  name.joint = joint;
  std::vector<std::string> words = NameWords(full);
  std::string base;
  for (const std::string& w : words) {
    if (IsRigWord(w)) continue;
    Side s = SideOf(w);
    if (s != kNoSide && name.side == kNoSide) {
      name.side = s;
      continue;
    }
    base += w;
  }
  base = StripLeadingZeros(base);
  // The ASF/AMC-style one-word names: lfemur, rhumerus, ltoes, lhipjoint.
  if (name.side == kNoSide && base.size() > 2 && (base[0] == 'l' || base[0] == 'r') &&
      KnownWord(base.substr(1)) && !KnownWord(base)) {
    name.side = base[0] == 'l' ? kLeft : kRight;
    base = base.substr(1);
  }
  name.base = base;
  return name;
}

// Levenshtein distance, for suggesting names.
size_t Distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

class Mapper {
 public:
  explicit Mapper(const SkeletonAnimation& skeleton) : s_(skeleton) {
    const size_t prefix = CommonPrefix();
    for (size_t j = 0; j < s_.joints.size(); ++j) {
      if (!s_.joints[j].end_site) {
        names_.push_back(Parse(static_cast<int>(j), s_.joints[j].name.substr(prefix)));
      }
    }
    depth_.assign(s_.joints.size(), 0);
    for (size_t j = 0; j < s_.joints.size(); ++j) {
      if (s_.joints[j].parent >= 0) depth_[j] = depth_[s_.joints[j].parent] + 1;
    }
  }

  AutoMapping Run() {
    AutoMapping result;
    result.scheme = Scheme();
    bool geometry_sides = false;
    std::map<std::string, int> parts = LimbParts(&geometry_sides, &result.notes);
    const int root = FindRoot(parts);
    parts["root"] = root;
    const int chest = FindChest(parts, root);
    parts["chest"] = chest;
    int neck = -1, head = -1;
    FindNeckAndHead(chest, &neck, &head, &result.notes);
    parts["neck"] = neck;
    parts["head"] = head;

    RequireParts(parts);
    result.mapping.origin = "auto (" + result.scheme + ")";
    for (const auto& [part, joint] : parts) {
      if (joint >= 0) result.mapping.joints[part] = s_.joints[joint].name;
    }
    for (const char* optional :
         {"neck", "head", "right_toe", "left_toe", "right_wrist", "left_wrist"}) {
      if (parts[optional] < 0) result.notes.push_back(std::string(optional) + " not found");
    }
    if (geometry_sides) result.scheme += ", sides from the rest pose";
    return result;
  }

 private:
  // The legs' and arms' joints by part ("left_knee"; -1 where none), and whether the rest pose
  // had to tell left from right.
  std::map<std::string, int> LimbParts(bool* geometry_sides,
                                       std::vector<std::string>* notes) const {
    // Legs and arms: a chain per side, each part below the one before.
    const std::vector<std::string> leg = {"hip", "knee", "ankle", "toe"};
    const std::vector<std::string> arm = {"shoulder", "elbow", "wrist"};
    std::map<Side, std::vector<int>> legs, arms;
    for (Side side : {kRight, kLeft}) {
      legs[side] = Chain(leg, side, -1);
      arms[side] = Chain(arm, side, -1);
    }
    if (legs[kRight][0] < 0 && legs[kLeft][0] < 0) {
      *geometry_sides = SidesFromRestPose(leg, arm, legs, arms);
      if (*geometry_sides) {
        notes->push_back("joint names do not say left or right: the rest pose decided");
      }
    }
    std::map<std::string, int> parts;
    for (Side side : {kRight, kLeft}) {
      const std::string prefix = side == kLeft ? "left_" : "right_";
      for (size_t i = 0; i < leg.size(); ++i) parts[prefix + leg[i]] = legs[side][i];
      for (size_t i = 0; i < arm.size(); ++i) parts[prefix + arm[i]] = arms[side][i];
    }
    return parts;
  }

  // No sided names: two unsided leg chains, told apart by the rest pose. False when there are
  // not two (`legs` and `arms` stay as they are).
  bool SidesFromRestPose(const std::vector<std::string>& leg, const std::vector<std::string>& arm,
                         std::map<Side, std::vector<int>>& legs,
                         std::map<Side, std::vector<int>>& arms) const {
    std::vector<std::vector<int>> unsided = UnsidedChains(leg);
    std::vector<std::vector<int>> unsided_arms = UnsidedChains(arm);
    if (unsided.size() == 2) {
      const bool first_left = IsLeft(unsided[0], unsided[1]);
      legs[kLeft] = unsided[first_left ? 0 : 1];
      legs[kRight] = unsided[first_left ? 1 : 0];
      if (unsided_arms.size() == 2) {
        const Vec3 left_dir = LeftDirection(legs[kLeft], legs[kRight]);
        const bool arm0_left =
            Dot(Sub(s_.rest[unsided_arms[0][0]].position, s_.rest[unsided_arms[1][0]].position),
                left_dir) > 0;
        arms[kLeft] = unsided_arms[arm0_left ? 0 : 1];
        arms[kRight] = unsided_arms[arm0_left ? 1 : 0];
      }
      return true;
    }
    return false;
  }

  // Root: a joint called hips/pelvis above both legs, else where the legs meet.
  int FindRoot(std::map<std::string, int>& parts) const {
    int root = -1;
    const int lh = parts["left_hip"], rh = parts["right_hip"];
    if (lh >= 0 && rh >= 0) {
      const int meet = CommonAncestor(lh, rh);
      root = Best("root", kNoSide, [&](int j) { return IsAncestor(j, meet); });
      if (root < 0) root = meet;
    } else {
      root = Best("root", kNoSide, [](int) { return true; });
    }
    return root;
  }

  // Chest: where the arms meet, above any neck or clavicle joint.
  int FindChest(std::map<std::string, int>& parts, int root) const {
    int chest = -1;
    const int ls = parts["left_shoulder"], rs = parts["right_shoulder"];
    if (ls >= 0 && rs >= 0) {
      chest = CommonAncestor(ls, rs);
      while (chest >= 0 && chest != root && IsNeckOrClavicle(chest))
        chest = s_.joints[chest].parent;
    }
    return chest;
  }

  // Neck and head: named joints above the chest, else the spine chain continued upwards.
  void FindNeckAndHead(int chest, int* neck_joint, int* head_joint,
                       std::vector<std::string>* notes) const {
    auto above_chest = [&](int j) { return chest < 0 || (j != chest && IsAncestor(chest, j)); };
    int head = Best("head", kNoSide, above_chest);
    int neck = Best("neck", kNoSide, [&](int j) {
      return above_chest(j) && (head < 0 || IsAncestor(j, head)) && j != head;
    });
    if (head < 0 && chest >= 0) {
      // Rigify's spine.004..006: the deepest joint that continues the chest's own word.
      const std::string stem = Stem(NameOf(chest).base);
      for (const Name& n : names_) {
        if (above_chest(n.joint) && n.side == kNoSide && !stem.empty() && Stem(n.base) == stem &&
            (head < 0 || depth_[n.joint] > depth_[head])) {
          head = n.joint;
        }
      }
      if (head >= 0) {
        int j = head;
        while (s_.joints[j].parent >= 0 && s_.joints[j].parent != chest) j = s_.joints[j].parent;
        if (j != head) neck = j;
        notes->push_back("no joint is called head: the spine's last joint is taken");
      }
    }
    *neck_joint = neck;
    *head_joint = head;
  }

  // Everything the retargeter needs must be there.
  void RequireParts(std::map<std::string, int>& parts) const {
    std::vector<std::string> missing;
    for (const char* required :
         {"root", "chest", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee",
          "left_ankle", "right_shoulder", "right_elbow", "left_shoulder", "left_elbow"}) {
      if (parts[required] < 0) missing.push_back(required);
    }
    if (!missing.empty()) Fail(missing);
  }

  // The length of a prefix every joint name shares up to a separator, such as the armature's
  // name Blender's COLLADA export puts before each bone ("walk_mixamorig_Hips"); 0 if none.
  size_t CommonPrefix() const {
    std::string prefix;
    bool first = true;
    for (const AnimatedJoint& j : s_.joints) {
      if (j.end_site) continue;
      if (first) {
        prefix = j.name;
        first = false;
        continue;
      }
      size_t n = 0;
      while (n < prefix.size() && n < j.name.size() && prefix[n] == j.name[n]) ++n;
      prefix.resize(n);
    }
    size_t cut = prefix.find_last_of("_:.| -");
    if (cut == std::string::npos) return 0;
    // Every name must keep something after the prefix.
    for (const AnimatedJoint& j : s_.joints) {
      if (!j.end_site && j.name.size() <= cut + 1) return 0;
    }
    return cut + 1;
  }

  const Name& NameOf(int joint) const {
    for (const Name& n : names_) {
      if (n.joint == joint) return n;
    }
    static const Name kNone;
    return kNone;
  }

  static std::string Stem(const std::string& base) {
    std::string stem;
    for (char c : base) {
      if (!std::isalpha(static_cast<unsigned char>(c))) break;
      stem += c;
    }
    return stem;
  }

  // The rank of `base` among a part's synonyms, or -1.
  static int Rank(const std::string& part, const std::string& base) {
    const auto& words = Synonyms().at(part);
    auto it = std::find(words.begin(), words.end(), base);
    if (it != words.end()) return static_cast<int>(it - words.begin());
    std::string bare = base;
    while (!bare.empty() && std::isdigit(static_cast<unsigned char>(bare.back()))) bare.pop_back();
    if (bare.empty() || bare == base) return -1;
    it = std::find(words.begin(), words.end(), bare);
    return it == words.end() ? -1 : 100 + static_cast<int>(it - words.begin());
  }

  // Joints that may play `part` on `side` (kNoSide: unsided joints), best first: synonym rank,
  // then nearest the root.
  std::vector<int> Candidates(const std::string& part, Side side) const {
    std::vector<std::pair<std::pair<int, int>, int>> ranked;
    for (const Name& n : names_) {
      if (n.side != side) continue;
      int r = Rank(part, n.base);
      if (r >= 0) ranked.push_back({{r, depth_[n.joint]}, n.joint});
    }
    std::sort(ranked.begin(), ranked.end());
    std::vector<int> joints;
    for (const auto& [key, j] : ranked) joints.push_back(j);
    return joints;
  }

  int Best(const std::string& part, Side side, const std::function<bool(int)>& fits) const {
    for (int j : Candidates(part, side)) {
      if (fits(j)) return j;
    }
    return -1;
  }

  // The best chain of `parts` on `side`, each below the previous (below `above` if >= 0); a
  // part without a fitting joint is -1 and the chain goes on below the last one found.
  std::vector<int> Chain(const std::vector<std::string>& parts, Side side, int above) const {
    std::vector<int> best(parts.size(), -1);
    int best_score = -1;
    std::vector<int> current(parts.size(), -1);
    // Depth-first over candidates; score = parts found, ties to the first (best-ranked) found.
    std::function<void(size_t, int, int)> search = [&](size_t i, int parent, int score) {
      if (i == parts.size()) {
        if (score > best_score) {
          best_score = score;
          best = current;
        }
        return;
      }
      for (int j : Candidates(parts[i], side)) {
        if (parent >= 0 && (j == parent || !IsAncestor(parent, j))) continue;
        current[i] = j;
        search(i + 1, j, score + 1);
        current[i] = -1;
        if (best_score == static_cast<int>(parts.size())) return;
      }
      search(i + 1, parent, score);  // the part is missing: the chain goes on below `parent`
    };
    search(0, above, 0);
    return best;
  }

  // Two chains of unsided joints (e.g. "Thigh" and "Thigh.001"), one per leg or arm.
  std::vector<std::vector<int>> UnsidedChains(const std::vector<std::string>& parts) const {
    std::vector<std::vector<int>> chains;
    for (int top : Candidates(parts[0], kNoSide)) {
      std::vector<int> chain =
          Chain(std::vector<std::string>(parts.begin() + 1, parts.end()), kNoSide, top);
      chain.insert(chain.begin(), top);
      if (chain[1] >= 0) chains.push_back(chain);
    }
    if (chains.size() > 2) chains.resize(2);
    return chains;
  }

  // Left of the facing direction in the rest pose: up from the feet to the hips, forward from
  // ankle to toe (or, without toes, the knees' forward bend is unknowable: fail).
  Vec3 LeftDirection(const std::vector<int>& a, const std::vector<int>& b) const {
    auto pos = [&](int j) { return s_.rest[j].position; };
    Vec3 up = Sub(pos(a[0]), pos(a[2] >= 0 ? a[2] : a[1]));
    Vec3 forward = {0, 0, 0};
    for (const auto* chain : {&a, &b}) {
      if ((*chain)[2] >= 0 && (*chain)[3] >= 0) {
        Vec3 f = Sub(pos((*chain)[3]), pos((*chain)[2]));
        forward = {forward[0] + f[0], forward[1] + f[1], forward[2] + f[2]};
      }
    }
    if (Dot(forward, forward) == 0) {
      throw ConfigError(s_.origin +
                        ": joint names do not say left or right and there are no toe joints to "
                        "tell the facing direction; give a mapping file (--map FILE)");
    }
    return Cross(up, forward);  // x forward, z up -> y left
  }

  bool IsLeft(const std::vector<int>& a, const std::vector<int>& b) const {
    const Vec3 left = LeftDirection(a, b);
    return Dot(Sub(s_.rest[a[0]].position, s_.rest[b[0]].position), left) > 0;
  }

  bool IsAncestor(int ancestor, int joint) const {
    for (int j = joint; j >= 0; j = s_.joints[j].parent) {
      if (j == ancestor) return true;
    }
    return false;
  }

  int CommonAncestor(int a, int b) const {
    for (int j = a; j >= 0; j = s_.joints[j].parent) {
      if (IsAncestor(j, b)) return j;
    }
    return -1;
  }

  bool IsNeckOrClavicle(int joint) const {
    const Name& n = NameOf(joint);
    return Rank("neck", n.base) >= 0 || n.base == "clavicle" || n.base == "collar" ||
           n.base == "shoulder" || Rank("head", n.base) >= 0;
  }

  // The naming recognised, for the user (informational: matching does not depend on it).
  std::string Scheme() const {
    std::set<std::string> lower;
    bool namespaced = false;
    for (const AnimatedJoint& j : s_.joints) {
      lower.insert(Lower(j.name.substr(j.name.rfind(':') + 1)));
      if (Lower(j.name).rfind("mixamorig", 0) == 0) namespaced = true;
    }
    auto has = [&](const char* n) { return lower.count(n) > 0; };
    if (namespaced) return "Mixamo";
    if (has("lfemur") && has("lhumerus")) return "CMU ASF (lfemur, lhumerus...)";
    if (has("lhipjoint") || has("lowerback")) return "CMU (Hips, LeftUpLeg, LeftArm...)";
    if (has("leftcollar") && has("lefthip")) return "CMU (Hips, LeftHip, LeftShoulder...)";
    if (has("pelvis") && has("thigh_l") && has("calf_l")) return "Unreal";
    if (has("leftupperleg") && has("leftlowerleg")) return "Unity humanoid";
    const bool biped = std::any_of(lower.begin(), lower.end(), [](const std::string& n) {
      return n.rfind("bip01", 0) == 0 || n.rfind("bip001", 0) == 0;
    });
    if (biped) return "3ds Max Biped";
    if (has("thigh.l") || has("def-thigh.l") || has("org-thigh.l")) return "Blender Rigify/metarig";
    if (has("lefttoe") && has("leftupleg")) return "LAFAN1";
    if (has("lefttoebase") && has("leftupleg")) return "Mixamo (no namespace)";
    if (has("left_hip") && has("left_knee") && has("chest")) return "ragdoll";
    return "unrecognised";
  }

  [[noreturn]] void Fail(const std::vector<std::string>& missing) const {
    std::string message = s_.origin + ": --map auto cannot find";
    for (const std::string& part : missing) {
      // The part's synonyms, sided as names usually are, against every joint name.
      std::string word = part;
      Side side = kNoSide;
      if (word.rfind("left_", 0) == 0) side = kLeft, word = word.substr(5);
      if (word.rfind("right_", 0) == 0) side = kRight, word = word.substr(6);
      const auto& synonyms =
          Synonyms().count(word) ? Synonyms().at(word) : std::vector<std::string>{word};
      std::vector<std::pair<size_t, std::string>> nearest;
      for (const Name& n : names_) {
        size_t d = 1000;
        for (const std::string& w : synonyms) d = std::min(d, Distance(n.base, w));
        if (side != kNoSide && n.side != side) d += 2;
        nearest.push_back({d, s_.joints[n.joint].name});
      }
      std::sort(nearest.begin(), nearest.end());
      message += "\n  " + part + " (a joint named like " + synonyms.front() +
                 (side == kLeft    ? ", on the left"
                  : side == kRight ? ", on the right"
                                   : "") +
                 "); nearest names:";
      for (size_t i = 0; i < nearest.size() && i < 3; ++i) message += " " + nearest[i].second;
    }
    message +=
        "\ngive a mapping file with --map FILE (part: JointName lines; see assets/mappings/)";
    throw ConfigError(message);
  }

  const SkeletonAnimation& s_;
  std::vector<Name> names_;
  std::vector<int> depth_;
};

}  // namespace

std::vector<std::string> NameWords(const std::string& full) {
  std::string name = full.substr(full.rfind(':') + 1);
  name = name.substr(name.rfind('|') + 1);
  std::vector<std::string> words;
  std::string word;
  auto flush = [&]() {
    if (!word.empty()) words.push_back(Lower(word));
    word.clear();
  };
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = name[i];
    if (!std::isalnum(c)) {
      flush();
      continue;
    }
    if (!word.empty()) {
      const unsigned char prev = name[i - 1];
      const bool next_lower =
          i + 1 < name.size() && std::islower(static_cast<unsigned char>(name[i + 1]));
      // camelCase: a capital after a small letter; "LHip": a capital before capital+small.
      if (std::isupper(c) && (std::islower(prev) || (std::isupper(prev) && next_lower))) flush();
      // a letter after digits starts a word ("Spine1Upper" keeps "spine1", "upper")
      else if (std::isalpha(c) && std::isdigit(prev))
        flush();
    }
    word += static_cast<char>(c);
  }
  flush();
  return words;
}

AutoMapping MapAutomatically(const SkeletonAnimation& skeleton) { return Mapper(skeleton).Run(); }

JointMapping ResolveMapping(const std::string& preset_or_path, const SkeletonAnimation& skeleton,
                            std::vector<std::string>* notes) {
  if (preset_or_path != "auto") return ReadJointMapping(preset_or_path);
  AutoMapping automatic = MapAutomatically(skeleton);
  if (notes) {
    std::string line = "mapping auto: " + automatic.scheme + ":";
    for (const std::string& part : MappingParts()) {
      auto it = automatic.mapping.joints.find(part);
      if (it != automatic.mapping.joints.end()) line += " " + part + "=" + it->second;
    }
    notes->push_back(line);
    for (const std::string& n : automatic.notes) notes->push_back("mapping auto: " + n);
  }
  return automatic.mapping;
}

}  // namespace ragdoll::motion
