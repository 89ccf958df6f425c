#include "common/keys.h"

#include <sys/stat.h>
#include <zmq.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace ragdoll {
namespace fs = std::filesystem;
namespace {

constexpr size_t kZ85KeyLength = 40;  // 32 bytes in Z85

[[noreturn]] void Fail(const std::string& path, int line, const std::string& message) {
  throw std::runtime_error(path + (line > 0 ? ":" + std::to_string(line) : "") + ": " + message);
}

bool ValidZ85Key(const std::string& key) {
  if (key.size() != kZ85KeyLength) return false;
  uint8_t bytes[32];
  return zmq_z85_decode(bytes, key.c_str()) != nullptr;
}

// A property line of ZeroMQ's property language (rfc.zeromq.org/spec:4/ZPL): `name = "value"`
// (quotes optional). Returns false when the line is not one.
bool ParseProperty(const std::string& line, std::string* name, std::string* value) {
  size_t eq = line.find('=');
  if (eq == std::string::npos) return false;
  auto trim = [](std::string s) {
    size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t\r");
    return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
  };
  *name = trim(line.substr(0, eq));
  *value = trim(line.substr(eq + 1));
  if (value->size() >= 2 && (value->front() == '"' || value->front() == '\'') &&
      value->back() == value->front()) {
    *value = value->substr(1, value->size() - 2);
  }
  return !name->empty();
}

std::string Quote(const std::string& value) {
  std::string quoted;
  for (char c : value) {
    if (c != '"' && c != '\n' && c != '\r') quoted += c;
  }
  return "\"" + quoted + "\"";
}

void WriteFile(const std::string& path, const std::string& text, mode_t mode) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    if (!out) Fail(temporary, 0, "cannot write");
    // Restrict before the secret goes in.
    if (chmod(temporary.c_str(), mode) != 0) Fail(temporary, 0, "cannot set its permissions");
    out << text;
    if (!out.flush()) Fail(temporary, 0, "cannot write");
  }
  fs::rename(temporary, path);
}

}  // namespace

KeyPaths KeyPathsOf(const std::string& keys_dir, const std::string& name, const std::string& role) {
  const fs::path dir(keys_dir);
  return {
      (role == "broker" ? dir / (name + ".key") : dir / (role + "s") / (name + ".key")).string(),
      (dir / (name + ".key_secret")).string()};
}

Certificate NewCertificate(const std::string& name, const std::string& role) {
  char public_key[kZ85KeyLength + 1], secret_key[kZ85KeyLength + 1];
  if (zmq_curve_keypair(public_key, secret_key) != 0) {
    throw std::runtime_error("this libzmq was built without CURVE (zmq_curve_keypair failed)");
  }
  return {public_key, secret_key, name, role};
}

void SaveCertificate(const Certificate& c, const std::string& public_path,
                     const std::string& secret_path) {
  char stamp[32];
  std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y-%m-%d %H:%M:%S", std::localtime(&now));
  auto text = [&](bool secret) {
    std::string t = std::string("#   ****  Generated on ") + stamp + " by ragdoll keygen  ****\n";
    if (secret) {
      t += "#   ZeroMQ CURVE **Secret** Certificate\n"
           "#   DO NOT PROVIDE THIS FILE TO OTHER USERS nor change its permissions.\n\n";
    } else {
      t += "#   ZeroMQ CURVE Public Certificate\n"
           "#   Exchange securely, or use a secure mechanism to verify the contents\n"
           "#   of this file after exchange.\n\n";
    }
    t += "metadata\n    name = " + Quote(c.name) + "\n";
    if (!c.role.empty()) t += "    role = " + Quote(c.role) + "\n";
    t += "curve\n    public-key = \"" + c.public_key + "\"\n";
    if (secret) t += "    secret-key = \"" + c.secret_key + "\"\n";
    return t;
  };
  for (const std::string& path : {public_path, secret_path}) {
    if (path.empty()) continue;
    fs::path parent = fs::path(path).parent_path();
    if (!parent.empty()) fs::create_directories(parent);
  }
  if (!public_path.empty()) WriteFile(public_path, text(false), 0644);
  if (!secret_path.empty() && !c.secret_key.empty()) WriteFile(secret_path, text(true), 0600);
}

Certificate LoadCertificate(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path, 0, "cannot read the certificate");
  Certificate c;
  std::string line, section, name, value;
  int number = 0, public_line = 0, secret_line = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.size() > 4096) Fail(path, number, "line too long for a certificate");
    size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    if (first == 0) {  // a section at the top level
      section = line.substr(0, line.find_last_not_of(" \t\r") + 1);
      continue;
    }
    if (!ParseProperty(line, &name, &value)) {
      Fail(path, number, "expected `name = \"value\"` (ZeroMQ certificate format)");
    }
    if (section == "curve" && name == "public-key") {
      c.public_key = value;
      public_line = number;
    } else if (section == "curve" && name == "secret-key") {
      c.secret_key = value;
      secret_line = number;
    } else if (section == "metadata" && name == "name") {
      c.name = value;
    } else if (section == "metadata" && name == "role") {
      c.role = value;
    }
  }
  if (c.public_key.empty()) Fail(path, 0, "no curve public-key: not a ZeroMQ CURVE certificate");
  if (!ValidZ85Key(c.public_key)) {
    Fail(path, public_line, "public-key is not a 40-character Z85 key");
  }
  if (!c.secret_key.empty()) {
    if (!ValidZ85Key(c.secret_key)) {
      Fail(path, secret_line, "secret-key is not a 40-character Z85 key");
    }
    char derived[kZ85KeyLength + 1];
    if (zmq_curve_public(derived, c.secret_key.c_str()) != 0 || c.public_key != derived) {
      Fail(path, secret_line, "secret-key does not belong to public-key");
    }
  }
  return c;
}

std::vector<Certificate> LoadPublicCertificates(const std::string& folder) {
  std::vector<std::string> files;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && entry.path().extension() == ".key") {
      files.push_back(entry.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  std::vector<Certificate> certificates;
  for (const auto& file : files) certificates.push_back(LoadCertificate(file));
  return certificates;
}

Curve LoadCurve(const std::string& keys_dir, const std::string& role,
                const std::string& own_certificate) {
  Curve curve;
  if (keys_dir.empty() && own_certificate.empty()) return curve;
  const std::string hint = " (make keys with `ragdoll keygen --keys " +
                           (keys_dir.empty() ? "keys" : keys_dir) +
                           "`; see deploy/README.md, \"Keys\")";
  const std::string broker = (fs::path(keys_dir) / "broker.key").string();
  if (!fs::exists(broker))
    Fail(broker, 0, "missing: every role needs the broker's public key" + hint);
  curve.server_key = LoadCertificate(broker).public_key;
  const std::string own = own_certificate.empty()
                              ? (fs::path(keys_dir) / (role + ".key_secret")).string()
                              : own_certificate;
  if (!fs::exists(own)) Fail(own, 0, "missing: the " + role + "'s own secret certificate" + hint);
  Certificate c = LoadCertificate(own);
  if (c.secret_key.empty()) Fail(own, 0, "holds no secret-key: give the .key_secret file");
  curve.public_key = c.public_key;
  curve.secret_key = c.secret_key;
  return curve;
}

bool IsLoopback(const std::string& address) {
  std::string a = address;
  if (a.size() >= 2 && a.front() == '[' && a.back() == ']') a = a.substr(1, a.size() - 2);
  return a == "localhost" || a == "::1" || a == "lo" || a.rfind("127.", 0) == 0;
}

}  // namespace ragdoll
