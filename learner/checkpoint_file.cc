#include "learner/checkpoint_file.h"

#include <fcntl.h>
#include <sodium.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace ragdoll::learner {
namespace {

constexpr const char* kMagic = "ragdoll-checkpoint 1 ";
constexpr size_t kMaxHeader = 256;

[[noreturn]] void Fail(const std::string& path, const std::string& message) {
  throw std::runtime_error(path + ": " + message);
}

// Writes all of `data` to `fd`; false with errno set on failure.
bool WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = ENOSPC;
      return false;
    }
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

std::string Sha256Hex(const std::string& data) {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
  unsigned char digest[crypto_hash_sha256_BYTES];
  crypto_hash_sha256(digest, reinterpret_cast<const unsigned char*>(data.data()), data.size());
  char hex[2 * crypto_hash_sha256_BYTES + 1];
  sodium_bin2hex(hex, sizeof(hex), digest, sizeof(digest));
  return hex;
}

void WriteCheckpointFile(const std::string& path, const std::string& payload) {
  const std::string header = std::string(kMagic) + "bytes=" + std::to_string(payload.size()) +
                             " sha256=" + Sha256Hex(payload) + "\n";
  const std::string temporary = path + ".tmp";
  int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) Fail(temporary, std::string("cannot create: ") + std::strerror(errno));
  bool ok = WriteAll(fd, header.data(), header.size()) &&
            WriteAll(fd, payload.data(), payload.size()) && ::fsync(fd) == 0;
  const int error = errno;
  if (::close(fd) != 0 && ok) ok = false;
  if (!ok) {
    ::unlink(temporary.c_str());
    Fail(temporary, std::string("cannot write the checkpoint (") + std::strerror(error) +
                        "); the previous checkpoints are untouched");
  }
  std::error_code rename_error;
  std::filesystem::rename(temporary, path, rename_error);
  if (rename_error) {
    ::unlink(temporary.c_str());
    Fail(path, "cannot rename the written checkpoint into place: " + rename_error.message());
  }
  // The rename itself reaches the disk with the folder.
  const std::string folder = std::filesystem::path(path).parent_path().string();
  int dir = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

std::string ReadCheckpointFile(const std::string& path, bool* verified) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot read");
  std::ostringstream all;
  all << in.rdbuf();
  std::string data = all.str();
  if (verified) *verified = false;
  if (data.rfind("PK", 0) == 0) return data;  // a libtorch archive written before checksums
  if (data.rfind(kMagic, 0) != 0) {
    if (data.empty()) Fail(path, "empty file: not a checkpoint");
    Fail(path, "not a ragdoll checkpoint (unknown header)");
  }
  const size_t end = data.find('\n');
  if (end == std::string::npos || end > kMaxHeader) Fail(path, "damaged header: no end of line");
  const std::string header = data.substr(0, end);
  unsigned long long bytes = 0;
  char hex[65] = {0};
  if (std::sscanf(header.c_str() + std::strlen(kMagic), "bytes=%llu sha256=%64[0-9a-f]", &bytes,
                  hex) != 2 ||
      std::strlen(hex) != 64) {
    Fail(path, "damaged header: '" + header + "'");
  }
  const size_t found = data.size() - end - 1;
  if (found != bytes) {
    Fail(path, std::string(found < bytes ? "truncated" : "has extra bytes") + ": " +
                   std::to_string(found) + " bytes of training state, the header says " +
                   std::to_string(bytes));
  }
  std::string payload = data.substr(end + 1);
  const std::string actual = Sha256Hex(payload);
  if (actual != hex) {
    Fail(path, "checksum mismatch (SHA-256 " + actual.substr(0, 12) + "..., written as " +
                   std::string(hex).substr(0, 12) + "...): the file changed after it was written");
  }
  if (verified) *verified = true;
  return payload;
}

std::string CheckCheckpointFile(const std::string& path) {
  try {
    ReadCheckpointFile(path);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace ragdoll::learner
