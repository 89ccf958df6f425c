#include "cli/keygen_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "common/keys.h"

namespace ragdoll::cli {
namespace {
namespace fs = std::filesystem;

struct KeygenOptions {
  std::string name, role, keys = "keys";
  bool force = false;
};

// Writes NAME's pair where its role finds it; returns 0, or 1 with a message on stderr.
int Generate(const KeygenOptions& o, const std::string& name, const std::string& role) {
  const KeyPaths paths = KeyPathsOf(o.keys, name, role);
  const fs::path secret = paths.secret_key, public_key = paths.public_key;
  if (!o.force && (fs::exists(secret) || fs::exists(public_key))) {
    std::fprintf(stderr,
                 "ragdoll keygen: %s already exists; keeping it (--force replaces it, and every "
                 "process using the old key must then get the new one)\n",
                 fs::exists(secret) ? secret.c_str() : public_key.c_str());
    return 1;
  }
  SaveCertificate(NewCertificate(name, role), public_key.string(), secret.string());
  std::printf("%-8s %s (secret, mode 0600) and %s\n", role.c_str(), secret.c_str(),
              public_key.c_str());
  return 0;
}

}  // namespace

std::function<int()> AddKeygenCommand(CLI::App& app) {
  auto o = std::make_shared<KeygenOptions>();
  auto* cmd = app.add_subcommand(
      "keygen", "make CURVE key pairs (without NAME: the broker's, an actor's and a learner's)");
  cmd->add_option("name", o->name, "whose key: a file name, e.g. actor-host7");
  cmd->add_option("--role", o->role, "broker, actor or learner (default: NAME when it is one)")
      ->check(CLI::IsMember({"broker", "actor", "learner"}));
  cmd->add_option("--keys", o->keys, "the keys folder")->capture_default_str();
  cmd->add_flag("--force", o->force, "replace existing keys");
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    try {
      if (o->name.empty()) {
        int failed = 0;
        for (const char* role : {"broker", "actor", "learner"}) failed |= Generate(*o, role, role);
        if (failed) return 1;
      } else {
        std::string role = o->role;
        if (role.empty()) {
          if (o->name != "broker" && o->name != "actor" && o->name != "learner") {
            std::fprintf(stderr,
                         "ragdoll keygen: say whose key %s is: --role actor|learner|broker\n",
                         o->name.c_str());
            return 2;
          }
          role = o->name;
        }
        if (int code = Generate(*o, o->name, role)) return code;
      }
      std::printf(
          "Give every role the keys folder (--keys %s, or security.keys in the config). Each "
          "machine needs broker.key and its own role's .key_secret; only the broker needs the "
          "actors/ and learners/ folders, and it picks up keys added there while it runs.\n",
          o->keys.c_str());
      return 0;
    } catch (const std::exception& error) {
      std::fprintf(stderr, "ragdoll keygen: %s\n", error.what());
      return 1;
    }
  };
}

}  // namespace ragdoll::cli
