// ZeroMQ CURVE security: key pairs stored as certificates in ZeroMQ's own text format (the one
// czmq's zcert and zauth read and write: NAME.key holds the public key, NAME.key_secret both),
// and the keys each role uses.
//
// The layout of a keys folder (`ragdoll keygen` writes it; deploy/README.md "Keys"):
//   broker.key, broker.key_secret     the broker's pair; every role needs broker.key
//   actor.key_secret, learner.key_secret   the pair an actor or learner uses by default
//   actors/*.key, learners/*.key      the public keys the broker accepts, per role
#pragma once

#include <string>
#include <vector>

namespace ragdoll {

struct Certificate {
  std::string public_key;  // Z85, 40 characters
  std::string secret_key;  // Z85, 40 characters; empty in a public certificate
  std::string name;        // metadata: who the key belongs to
  std::string role;        // metadata: broker, actor or learner (may be empty)
};

// Where a pair of `role` named `name` lives in a keys folder (the layout above): the secret at
// KEYS/NAME.key_secret; the public key at KEYS/NAME.key for the broker (every role reads it),
// else in the folder the broker accepts that role's keys from, KEYS/ROLEs/NAME.key.
struct KeyPaths {
  std::string public_key, secret_key;
};
KeyPaths KeyPathsOf(const std::string& keys_dir, const std::string& name, const std::string& role);

// A fresh key pair (libzmq's zmq_curve_keypair).
Certificate NewCertificate(const std::string& name, const std::string& role);

// Writes the public certificate to `public_path` and, when the certificate has a secret key,
// the secret one to `secret_path` with mode 0600. Throws std::runtime_error naming the file.
void SaveCertificate(const Certificate& certificate, const std::string& public_path,
                     const std::string& secret_path);

// Reads a public or secret certificate. Throws std::runtime_error naming the file and line for
// anything that is not a valid certificate (bad Z85, wrong length, a secret key that does not
// match its public key).
Certificate LoadCertificate(const std::string& path);

// Every public certificate (*.key) in `folder`, sorted by file name. Throws naming the file for
// a bad one; a missing folder gives none.
std::vector<Certificate> LoadPublicCertificates(const std::string& folder);

// The CURVE keys of one process. Empty server_key: plaintext.
struct Curve {
  std::string server_key;  // the broker's public key, Z85
  std::string public_key;  // this process's own pair, Z85
  std::string secret_key;
  bool enabled() const { return !server_key.empty(); }
};

// The keys of `role` (broker, actor or learner) from the keys folder: the broker's public key
// and the role's own pair, read from `own_certificate` when given, else from
// KEYS/ROLE.key_secret. Throws std::runtime_error naming the missing or bad file and how to make
// one. An empty `keys_dir` gives plaintext.
Curve LoadCurve(const std::string& keys_dir, const std::string& role,
                const std::string& own_certificate = "");

// Whether a bind or connect address names this machine's loopback interface only.
bool IsLoopback(const std::string& address);

}  // namespace ragdoll
