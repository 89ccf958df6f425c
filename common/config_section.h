// Reading experiment configuration from YAML, validated once at start-up.
//
// Every component has one config struct and one function that fills it from a ConfigSection.
// The section records which keys were read so that Finish() can reject any key nobody asked for,
// naming the file, the line and the closest valid key (a typo must never be silently ignored).
#pragma once

#include <yaml-cpp/yaml.h>

#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace ragdoll {

// A start-up error in a configuration or data file. what() names the file, the place and the
// offending value.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws ConfigError "where: message", the shape of every error about a file read at start-up
// (`where`: the file, file:line, or the file and a key), so that readers need no local Fail().
[[noreturn]] void ThrowConfigError(const std::string& where, const std::string& message);

class ConfigSection {
 public:
  // Parses a YAML file whose top level is a mapping. Throws ConfigError naming the file on
  // syntax errors.
  static ConfigSection FromFile(const std::string& path);
  // Parses YAML text; `origin` names it in error messages.
  static ConfigSection FromString(const std::string& text, const std::string& origin);

  // Optional scalar: `fallback` when the key is absent. Throws naming the key when present but
  // not convertible to T.
  template <typename T>
  T Get(const std::string& key, const T& fallback) const;
  // Optional list of strings.
  std::vector<std::string> GetStringList(const std::string& key,
                                         const std::vector<std::string>& fallback) const;
  // Optional TCP port (1-65535).
  int GetPort(const std::string& key, int fallback) const;
  // A string naming a file: relative paths are resolved against the config file's folder.
  std::string GetPath(const std::string& key, const std::string& fallback) const;
  bool Has(const std::string& key) const;
  // Whether the key is present and holds a list (for keys that take a word or a list).
  bool IsList(const std::string& key) const;

  // A nested mapping (an empty one when absent). Its keys are checked by its own Finish().
  ConfigSection Section(const std::string& key) const;
  // A list of mappings (empty when absent), each named key[i] in error messages.
  std::vector<ConfigSection> SectionList(const std::string& key) const;

  // Throws ConfigError naming every key of this mapping that was never read, with a hint.
  void Finish() const;

  // Throws ConfigError "file:line: prefix.key: message".
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const;

  // A copy of this section's parsed YAML, to edit (an effective configuration to write out)
  // without reading the file again.
  YAML::Node Clone() const { return YAML::Clone(node_); }

  const std::string& file() const { return file_; }
  // Folder of the config file, for resolving relative paths ("." for in-memory text).
  const std::string& base_dir() const { return base_dir_; }

 private:
  ConfigSection(YAML::Node node, std::string file, std::string base_dir, std::string prefix,
                int line);
  YAML::Node Lookup(const std::string& key) const;
  std::string Where(const std::string& key) const;

  YAML::Node node_;
  std::string file_;
  std::string base_dir_;
  std::string prefix_;
  int line_ = 0;
  std::shared_ptr<std::set<std::string>> read_keys_;
};

// Levenshtein distance, for "did you mean" hints.
int EditDistance(const std::string& a, const std::string& b);

// --- template implementation ---

template <typename T>
T ConfigSection::Get(const std::string& key, const T& fallback) const {
  YAML::Node value = Lookup(key);
  if (!value) return fallback;
  if (!value.IsScalar()) Fail(key, "expected a single value");
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    Fail(key, "cannot read '" + value.Scalar() + "' as the expected type");
  }
}

}  // namespace ragdoll
