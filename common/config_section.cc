#include "common/config_section.h"

#include <algorithm>
#include <filesystem>
#include <limits>
#include <sstream>

namespace ragdoll {

void ThrowConfigError(const std::string& where, const std::string& message) {
  throw ConfigError(where + ": " + message);
}

ConfigSection::ConfigSection(YAML::Node node, std::string file, std::string base_dir,
                             std::string prefix, int line)
    : node_(std::move(node)),
      file_(std::move(file)),
      base_dir_(std::move(base_dir)),
      prefix_(std::move(prefix)),
      line_(line),
      read_keys_(std::make_shared<std::set<std::string>>()) {}

ConfigSection ConfigSection::FromFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open config file");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) +
                      ": YAML syntax error: " + e.msg);
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) throw ConfigError(path + ": the top level must be a mapping of keys");
  std::string base = std::filesystem::path(path).parent_path().string();
  return ConfigSection(root, path, base.empty() ? "." : base, "", 1);
}

ConfigSection ConfigSection::FromString(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(origin + ":" + std::to_string(e.mark.line + 1) +
                      ": YAML syntax error: " + e.msg);
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) throw ConfigError(origin + ": the top level must be a mapping of keys");
  return ConfigSection(root, origin, ".", "", 1);
}

YAML::Node ConfigSection::Lookup(const std::string& key) const {
  read_keys_->insert(key);
  if (!node_.IsMap()) return YAML::Node();
  // operator[] on a const node does not insert.
  const YAML::Node& const_node = node_;
  YAML::Node value = const_node[key];
  // A key without a value ("motion:") counts as absent.
  if (value && value.IsNull()) return YAML::Node(YAML::NodeType::Undefined);
  return value;
}

bool ConfigSection::Has(const std::string& key) const { return static_cast<bool>(Lookup(key)); }

bool ConfigSection::IsList(const std::string& key) const {
  YAML::Node value = Lookup(key);
  return value && value.IsSequence();
}

std::vector<std::string> ConfigSection::GetStringList(
    const std::string& key, const std::vector<std::string>& fallback) const {
  YAML::Node value = Lookup(key);
  if (!value) return fallback;
  if (!value.IsSequence()) Fail(key, "expected a list, e.g. [a, b]");
  std::vector<std::string> out;
  for (const auto& item : value) {
    if (!item.IsScalar()) Fail(key, "every list item must be a single value");
    out.push_back(item.Scalar());
  }
  return out;
}

int ConfigSection::GetPort(const std::string& key, int fallback) const {
  int port = Get<int>(key, fallback);
  if (port < 1 || port > 65535) Fail(key, "must be a TCP port (1-65535)");
  return port;
}

std::string ConfigSection::GetPath(const std::string& key, const std::string& fallback) const {
  std::string value = Get<std::string>(key, fallback);
  if (value.empty()) return value;
  std::filesystem::path p(value);
  if (p.is_absolute() || !Has(key)) return value;
  return (std::filesystem::path(base_dir_) / p).lexically_normal().string();
}

ConfigSection ConfigSection::Section(const std::string& key) const {
  YAML::Node value = Lookup(key);
  std::string prefix = prefix_.empty() ? key : prefix_ + "." + key;
  if (!value) {
    return ConfigSection(YAML::Node(YAML::NodeType::Map), file_, base_dir_, prefix, line_);
  }
  if (!value.IsMap()) Fail(key, "expected a mapping of keys");
  return ConfigSection(value, file_, base_dir_, prefix, value.Mark().line + 1);
}

std::vector<ConfigSection> ConfigSection::SectionList(const std::string& key) const {
  YAML::Node value = Lookup(key);
  std::vector<ConfigSection> out;
  if (!value) return out;
  if (!value.IsSequence()) Fail(key, "expected a list of mappings");
  std::string prefix = prefix_.empty() ? key : prefix_ + "." + key;
  for (size_t i = 0; i < value.size(); ++i) {
    YAML::Node item = value[i];
    if (!item.IsMap()) Fail(key, "item " + std::to_string(i + 1) + ": expected a mapping of keys");
    out.push_back(ConfigSection(item, file_, base_dir_, prefix + "[" + std::to_string(i) + "]",
                                item.Mark().line + 1));
  }
  return out;
}

std::string ConfigSection::Where(const std::string& key) const {
  int line = line_;
  if (node_.IsMap()) {
    const YAML::Node& const_node = node_;
    YAML::Node value = const_node[key];
    if (value) line = value.Mark().line + 1;
  }
  std::ostringstream out;
  out << file_;
  if (line > 0) out << ":" << line;
  out << ": " << (prefix_.empty() ? key : prefix_ + "." + key);
  return out.str();
}

void ConfigSection::Fail(const std::string& key, const std::string& message) const {
  throw ConfigError(Where(key) + ": " + message);
}

void ConfigSection::Finish() const {
  if (!node_.IsMap()) return;
  for (const auto& item : node_) {
    std::string key = item.first.Scalar();
    if (read_keys_->count(key)) continue;
    std::string hint;
    int best = std::numeric_limits<int>::max();
    for (const auto& known : *read_keys_) {
      int d = EditDistance(key, known);
      if (d < best) {
        best = d;
        hint = known;
      }
    }
    std::ostringstream out;
    out << file_ << ":" << item.first.Mark().line + 1 << ": unknown key '"
        << (prefix_.empty() ? key : prefix_ + "." + key) << "'";
    if (!hint.empty() && best <= std::max<int>(3, static_cast<int>(key.size()) / 2)) {
      out << "; did you mean '" << hint << "'?";
    } else if (!read_keys_->empty()) {
      out << "; valid keys here:";
      for (const auto& known : *read_keys_) out << " " << known;
    }
    throw ConfigError(out.str());
  }
}

int EditDistance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j) {
      int substitute = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, substitute});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

}  // namespace ragdoll
