#include "motion/bvh.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/config_section.h"

namespace ragdoll::motion {

using character::AxisAngle;
using character::Multiply;
using character::Normalized;
using character::Quat;
using character::Vec3;

namespace {

constexpr double kDegrees = M_PI / 180.0;
constexpr int kMaxDepth = 256;

struct Token {
  std::string text;
  int line;
};

// Whitespace-separated tokens of the hierarchy with their line numbers; braces are tokens even
// when written against a word ("{OFFSET").
class Tokens {
 public:
  Tokens(const std::vector<std::string>& lines, size_t begin, size_t end, std::string origin)
      : origin_(std::move(origin)) {
    for (size_t i = begin; i < end; ++i) {
      std::string spaced;
      for (char c : lines[i]) {
        if (c == '{' || c == '}') {
          spaced += ' ';
          spaced += c;
          spaced += ' ';
        } else {
          spaced += c;
        }
      }
      std::istringstream words(spaced);
      for (std::string w; words >> w;) tokens_.push_back({w, static_cast<int>(i) + 1});
    }
    last_line_ = static_cast<int>(end);
  }
  bool done() const { return next_ >= tokens_.size(); }
  const Token& Peek() const {
    if (done()) Fail(last_line_, "unexpected end of the hierarchy");
    return tokens_[next_];
  }
  Token Take() {
    Token t = Peek();
    ++next_;
    return t;
  }
  void Expect(const std::string& word) {
    Token t = Take();
    if (t.text != word) Fail(t.line, "expected '" + word + "', found '" + t.text + "'");
  }
  // A number; `what` says what it belongs to when the token is something else.
  double Number(const std::string& what) {
    Token t = Take();
    char* end = nullptr;
    errno = 0;
    double v = std::strtod(t.text.c_str(), &end);
    if (end == t.text.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
      Fail(t.line, what + ": '" + t.text + "' is not a finite number");
    }
    return v;
  }
  [[noreturn]] void Fail(int line, const std::string& message) const {
    throw ConfigError(origin_ + ":" + std::to_string(line) + ": " + message);
  }

 private:
  std::string origin_;
  std::vector<Token> tokens_;
  size_t next_ = 0;
  int last_line_ = 0;
};

BvhChannel ParseChannel(const Token& t, const Tokens& tokens) {
  static const std::pair<const char*, BvhChannel> kNames[] = {
      {"Xposition", BvhChannel::kXposition}, {"Yposition", BvhChannel::kYposition},
      {"Zposition", BvhChannel::kZposition}, {"Xrotation", BvhChannel::kXrotation},
      {"Yrotation", BvhChannel::kYrotation}, {"Zrotation", BvhChannel::kZrotation}};
  for (const auto& [name, channel] : kNames) {
    // Some exporters write the axis in lower case ("xrotation"); accept any case.
    if (t.text.size() == std::string(name).size()) {
      bool same = true;
      for (size_t i = 0; i < t.text.size(); ++i) {
        same &= std::tolower(static_cast<unsigned char>(t.text[i])) ==
                std::tolower(static_cast<unsigned char>(name[i]));
      }
      if (same) return channel;
    }
  }
  tokens.Fail(t.line, "unknown channel '" + t.text + "' (expected X/Y/Z position or rotation)");
}

// JOINT/ROOT body after the name: { OFFSET x y z CHANNELS n ... children }.
void ParseJoint(Tokens& tokens, BvhMotion* motion, int parent, const Token& name, int depth) {
  if (depth > kMaxDepth) tokens.Fail(name.line, "hierarchy nested more than 256 levels");
  BvhJoint joint;
  joint.name = name.text;
  joint.parent = parent;
  tokens.Expect("{");
  tokens.Expect("OFFSET");
  for (double& o : joint.offset) o = tokens.Number("OFFSET of '" + joint.name + "' (3 numbers)");
  tokens.Expect("CHANNELS");
  Token count = tokens.Peek();
  double n = tokens.Number("CHANNELS count of '" + joint.name + "'");
  if (n < 0 || n > 6 || n != std::floor(n)) {
    tokens.Fail(count.line, "CHANNELS count must be 0 to 6, found '" + count.text + "'");
  }
  for (int i = 0; i < static_cast<int>(n); ++i) {
    Token c = tokens.Take();
    if (c.text == "JOINT" || c.text == "End" || c.text == "}" || c.text == "{") {
      tokens.Fail(c.line, "joint '" + joint.name + "' declares " + count.text +
                              " channels but lists " + std::to_string(i));
    }
    joint.channels.push_back(ParseChannel(c, tokens));
  }
  joint.first_channel = motion->channel_count;
  motion->channel_count += static_cast<int>(joint.channels.size());
  const int index = static_cast<int>(motion->joints.size());
  for (const auto& j : motion->joints) {
    if (!j.end_site && j.name == joint.name) {
      tokens.Fail(name.line, "joint name '" + joint.name + "' used twice");
    }
  }
  motion->joints.push_back(joint);
  for (;;) {
    Token t = tokens.Take();
    if (t.text == "}") return;
    if (t.text == "JOINT") {
      Token child = tokens.Take();
      ParseJoint(tokens, motion, index, child, depth + 1);
    } else if (t.text == "End") {
      tokens.Expect("Site");
      BvhJoint end;
      end.name = motion->joints[index].name + "_end";
      end.parent = index;
      end.end_site = true;
      end.first_channel = motion->channel_count;
      tokens.Expect("{");
      tokens.Expect("OFFSET");
      for (double& o : end.offset)
        o = tokens.Number("OFFSET of the End Site of '" + motion->joints[index].name + "'");
      tokens.Expect("}");
      motion->joints.push_back(end);
    } else {
      tokens.Fail(t.line, "expected JOINT, End Site or '}' in joint '" +
                              motion->joints[index].name + "', found '" + t.text + "'");
    }
  }
}

// "Frames: 120" or "Frame Time: 0.0083333": the value after the label on its line.
std::string ValueAfter(const std::string& line, const std::string& label) {
  std::string rest = line.substr(label.size());
  size_t a = rest.find_first_not_of(" \t");
  size_t b = rest.find_last_not_of(" \t");
  return a == std::string::npos ? "" : rest.substr(a, b - a + 1);
}

// The text's lines, without a Windows line end's '\r'.
std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines.push_back(line);
    }
  }
  return lines;
}

[[noreturn]] void FailAtLine(const std::string& origin, size_t line, const std::string& message) {
  throw ConfigError(origin + ":" + std::to_string(line) + ": " + message);
}

std::string Trimmed(const std::string& s) {
  size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return std::string();
  return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}

// Where the sections start: the HIERARCHY line (the first that is not empty) and the MOTION line.
void FindSections(const std::vector<std::string>& lines, const std::string& origin, size_t* first,
                  size_t* motion_line) {
  *first = 0;
  while (*first < lines.size() && Trimmed(lines[*first]).empty()) ++*first;
  if (*first == lines.size() || Trimmed(lines[*first]) != "HIERARCHY") {
    FailAtLine(origin, *first + 1, "a BVH file starts with HIERARCHY");
  }
  *motion_line = *first + 1;
  while (*motion_line < lines.size() && Trimmed(lines[*motion_line]) != "MOTION") ++*motion_line;
  if (*motion_line == lines.size()) FailAtLine(origin, lines.size(), "no MOTION section");
}

// The joints between HIERARCHY and MOTION: one ROOT and its descendants.
void ParseHierarchy(const std::vector<std::string>& lines, size_t first, size_t motion_line,
                    const std::string& origin, BvhMotion* motion) {
  Tokens tokens(lines, first + 1, motion_line, origin);
  Token root = tokens.Take();
  if (root.text != "ROOT") tokens.Fail(root.line, "expected ROOT, found '" + root.text + "'");
  Token root_name = tokens.Take();
  ParseJoint(tokens, motion, -1, root_name, 0);
  if (!tokens.done()) {
    Token extra = tokens.Take();
    tokens.Fail(extra.line, "unexpected '" + extra.text + "' after the root joint (one ROOT only)");
  }
  if (motion->channel_count == 0) FailAtLine(origin, root.line, "no joint has channels");
}

// "Frames: N" and "Frame Time: t" from `*line_at` on (sets the motion's frame_time); leaves
// `*line_at` after them. Returns N, as a number and as written.
long ParseFrameCount(const std::vector<std::string>& lines, size_t* line_at, BvhMotion* motion,
                     std::string* frames_written) {
  const std::string& origin = motion->origin;
  size_t& line = *line_at;
  auto next_nonempty = [&]() {
    while (line < lines.size() && Trimmed(lines[line]).empty()) ++line;
  };
  next_nonempty();
  if (line >= lines.size() || Trimmed(lines[line]).rfind("Frames:", 0) != 0) {
    FailAtLine(origin, line + 1, "expected 'Frames: N' after MOTION");
  }
  const std::string frames_text = ValueAfter(Trimmed(lines[line]), "Frames:");
  char* end = nullptr;
  const long frames = std::strtol(frames_text.c_str(), &end, 10);
  if (frames_text.empty() || *end != '\0' || frames < 1 || frames > 10000000) {
    FailAtLine(origin, line + 1,
               "'Frames:' needs a positive whole number, found '" + frames_text + "'");
  }
  ++line;
  next_nonempty();
  if (line >= lines.size() || Trimmed(lines[line]).rfind("Frame Time:", 0) != 0) {
    FailAtLine(origin, line + 1, "expected 'Frame Time: seconds' after 'Frames:'");
  }
  const std::string time_text = ValueAfter(Trimmed(lines[line]), "Frame Time:");
  motion->frame_time = std::strtod(time_text.c_str(), &end);
  if (time_text.empty() || *end != '\0' || !(motion->frame_time > 0) ||
      !std::isfinite(motion->frame_time)) {
    FailAtLine(origin, line + 1,
               "'Frame Time:' needs a positive number of seconds, found '" + time_text + "'");
  }
  ++line;
  *frames_written = frames_text;
  return frames;
}

// One frame's values from its (trimmed) line, `line` counting from 0; as many as the channels.
std::vector<double> ParseFrameRow(const std::string& row, size_t line, const BvhMotion& motion) {
  const std::string& origin = motion.origin;
  char* end = nullptr;
  std::vector<double> values;
  values.reserve(motion.channel_count);
  const char* p = row.c_str();
  while (*p) {
    while (*p == ' ' || *p == '\t') ++p;
    if (!*p) break;
    const char* start = p;
    while (*p && *p != ' ' && *p != '\t') ++p;
    std::string word(start, p);
    errno = 0;
    double v = std::strtod(word.c_str(), &end);
    if (*end != '\0' || errno == ERANGE || !std::isfinite(v)) {
      FailAtLine(origin, line + 1,
                 "frame " + std::to_string(motion.frames.size()) + ": '" + word +
                     "' is not a finite number");
    }
    values.push_back(v);
  }
  if (static_cast<int>(values.size()) != motion.channel_count) {
    FailAtLine(origin, line + 1,
               "frame " + std::to_string(motion.frames.size()) + " has " +
                   std::to_string(values.size()) + " values; the hierarchy declares " +
                   std::to_string(motion.channel_count) + " channels");
  }
  return values;
}

// The frame lines from `line` on: the `frames` that 'Frames:' declares (`frames_text`).
void ParseFrames(const std::vector<std::string>& lines, size_t line, long frames,
                 const std::string& frames_text, BvhMotion* motion) {
  motion->frames.reserve(static_cast<size_t>(frames));
  for (; line < lines.size(); ++line) {
    const std::string row = Trimmed(lines[line]);
    if (row.empty()) continue;
    if (static_cast<long>(motion->frames.size()) == frames) {
      // Real files miscount (Assimp's test capture Boxing_Toes.bvh has one line more than its
      // 'Frames:'): the declared frames are read, the rest is reported, not guessed at.
      size_t extra = 0;
      for (size_t l = line; l < lines.size(); ++l) extra += !Trimmed(lines[l]).empty();
      motion->notes.push_back(motion->origin + ":" + std::to_string(line + 1) + ": " +
                              std::to_string(extra) + " line" + (extra == 1 ? "" : "s") +
                              " after the " + frames_text + " frames 'Frames:' declares: ignored");
      break;
    }
    motion->frames.push_back(ParseFrameRow(row, line, *motion));
  }
  if (static_cast<long>(motion->frames.size()) < frames) {
    FailAtLine(motion->origin, lines.size(),
               "truncated: 'Frames: " + frames_text + "' but " +
                   std::to_string(motion->frames.size()) + " frame lines");
  }
}

}  // namespace

int BvhMotion::Find(const std::string& name) const {
  for (size_t i = 0; i < joints.size(); ++i) {
    if (!joints[i].end_site && joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

Quat BvhMotion::LocalRotation(int frame, int joint) const {
  const BvhJoint& j = joints[joint];
  const std::vector<double>& values = frames[frame];
  Quat q = {1, 0, 0, 0};
  for (size_t c = 0; c < j.channels.size(); ++c) {
    const double angle = values[j.first_channel + c] * kDegrees;
    switch (j.channels[c]) {
      case BvhChannel::kXrotation:
        q = Multiply(q, AxisAngle({1, 0, 0}, angle));
        break;
      case BvhChannel::kYrotation:
        q = Multiply(q, AxisAngle({0, 1, 0}, angle));
        break;
      case BvhChannel::kZrotation:
        q = Multiply(q, AxisAngle({0, 0, 1}, angle));
        break;
      default:
        break;
    }
  }
  return Normalized(q);
}

Vec3 BvhMotion::LocalTranslation(int frame, int joint) const {
  const BvhJoint& j = joints[joint];
  Vec3 t = j.offset;
  for (size_t c = 0; c < j.channels.size(); ++c) {
    const double v = frames[frame][j.first_channel + c];
    switch (j.channels[c]) {
      case BvhChannel::kXposition:
        t[0] = v;
        break;
      case BvhChannel::kYposition:
        t[1] = v;
        break;
      case BvhChannel::kZposition:
        t[2] = v;
        break;
      default:
        break;
    }
  }
  return t;
}

BvhMotion ParseBvh(const std::string& text, const std::string& origin) {
  const std::vector<std::string> lines = SplitLines(text);
  size_t first = 0, motion_line = 0;
  FindSections(lines, origin, &first, &motion_line);

  BvhMotion motion;
  motion.origin = origin;
  ParseHierarchy(lines, first, motion_line, origin, &motion);

  // MOTION: "Frames: N", "Frame Time: t", then N lines of channel_count values.
  size_t line = motion_line + 1;
  std::string frames_text;
  const long frames = ParseFrameCount(lines, &line, &motion, &frames_text);
  ParseFrames(lines, line, frames, frames_text, &motion);
  return motion;
}

BvhMotion LoadBvh(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseBvh(text.str(), path);
}

}  // namespace ragdoll::motion
