#include "common/wire.h"

#include <google/protobuf/stubs/logging.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace ragdoll::wire {
namespace {

// protobuf logs an ERROR line for every string field with invalid UTF-8 it parses: at a network
// edge any sender could flood the logs with them. Those messages are rejected and counted by the
// callers; of protobuf's own lines the log keeps at most one a minute, with the count of the rest.
void RateLimitedProtobufLog(google::protobuf::LogLevel level, const char* file, int line,
                            const std::string& message) {
  static std::atomic<int64_t> last_ns{0}, suppressed{0};
  const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now().time_since_epoch())
                          .count();
  const int64_t last = last_ns.load();
  if (level != google::protobuf::LOGLEVEL_FATAL && last != 0 && now - last < 60'000'000'000) {
    suppressed.fetch_add(1);
    return;
  }
  last_ns.store(now);
  std::fprintf(stderr, "[protobuf %s:%d] %s (%lld similar lines in the last minute not shown)\n",
               file, line, message.c_str(), static_cast<long long>(suppressed.exchange(0)));
}
[[maybe_unused]] const bool kProtobufLogRateLimited =
    (google::protobuf::SetLogHandler(&RateLimitedProtobufLog), true);

Verdict Reject(Rejection r, std::string detail) { return Verdict{r, std::move(detail)}; }

size_t DTypeSize(v1::Tensor::DType d) {
  switch (d) {
    case v1::Tensor::DTYPE_FLOAT32:
      return 4;
    case v1::Tensor::DTYPE_UINT8:
      return 1;
    case v1::Tensor::DTYPE_INT64:
      return 8;
    default:
      return 0;
  }
}

std::string ShapeString(const v1::Tensor& t) {
  std::string s = "[";
  for (int i = 0; i < t.shape_size(); ++i) s += (i ? ", " : "") + std::to_string(t.shape(i));
  return s + "]";
}

}  // namespace

const char* RejectionName(Rejection r) {
  switch (r) {
    case Rejection::kNone:
      return "none";
    case Rejection::kMalformed:
      return "malformed";
    case Rejection::kVersion:
      return "version";
    case Rejection::kKind:
      return "kind";
    case Rejection::kSizeMismatch:
      return "size_mismatch";
    case Rejection::kOversized:
      return "oversized";
    case Rejection::kShape:
      return "shape";
    case Rejection::kNonFinite:
      return "non_finite";
    case Rejection::kRunId:
      return "run_id";
  }
  return "unknown";
}

std::string Pack(v1::Kind kind, const std::string& run_id, const std::string& sender,
                 const google::protobuf::MessageLite& payload, int64_t policy_version) {
  v1::Header h;
  h.set_protocol_version(kProtocolVersion);
  h.set_kind(kind);
  h.set_run_id(run_id);
  h.set_sender(sender);
  h.set_payload_bytes(payload.ByteSizeLong());
  h.set_policy_version(policy_version);
  const uint32_t header_size = static_cast<uint32_t>(h.ByteSizeLong());
  std::string out(4 + header_size + h.payload_bytes(), '\0');
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>((header_size >> (8 * i)) & 0xff);
  h.SerializeToArray(&out[4], static_cast<int>(header_size));
  payload.SerializeToArray(&out[4 + header_size], static_cast<int>(h.payload_bytes()));
  return out;
}

std::string PackEmpty(v1::Kind kind, const std::string& run_id, const std::string& sender) {
  v1::Header empty_payload_marker;  // any message with no fields serialises to zero bytes
  return Pack(kind, run_id, sender, empty_payload_marker);
}

Verdict ReadHeader(const void* data, size_t size, size_t max_message_bytes, v1::Header* header,
                   size_t* payload_offset) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  if (size < 4) return Reject(Rejection::kMalformed, "message shorter than its length prefix");
  if (size > max_message_bytes) {
    return Reject(Rejection::kOversized,
                  std::to_string(size) + " bytes, limit " + std::to_string(max_message_bytes));
  }
  uint32_t header_size = 0;
  for (int i = 0; i < 4; ++i) header_size |= static_cast<uint32_t>(bytes[i]) << (8 * i);
  if (header_size > size - 4) {
    return Reject(Rejection::kMalformed, "header length " + std::to_string(header_size) +
                                             " exceeds the message (" + std::to_string(size) +
                                             " bytes)");
  }
  if (!header->ParseFromArray(bytes + 4, static_cast<int>(header_size))) {
    return Reject(Rejection::kMalformed, "header does not parse");
  }
  if (header->protocol_version() != kProtocolVersion) {
    return Reject(Rejection::kVersion,
                  "protocol version " + std::to_string(header->protocol_version()) +
                      ", this build speaks " + std::to_string(kProtocolVersion));
  }
  if (header->kind() == v1::KIND_UNSPECIFIED || !v1::Kind_IsValid(header->kind())) {
    return Reject(Rejection::kKind, "unknown message kind " + std::to_string(header->kind()));
  }
  size_t payload_size = size - 4 - header_size;
  if (header->payload_bytes() != payload_size) {
    return Reject(Rejection::kSizeMismatch,
                  "header says " + std::to_string(header->payload_bytes()) +
                      " payload bytes, message has " + std::to_string(payload_size));
  }
  *payload_offset = 4 + header_size;
  return {};
}

Verdict ReadMessage(const void* data, size_t size, size_t max_message_bytes, v1::Header* header,
                    google::protobuf::MessageLite* message) {
  size_t offset = 0;
  Verdict v = ReadHeader(data, size, max_message_bytes, header, &offset);
  if (!v.ok()) return v;
  if (!message->ParseFromArray(static_cast<const char*>(data) + offset,
                               static_cast<int>(size - offset))) {
    return Reject(Rejection::kMalformed, "payload does not parse as " + message->GetTypeName());
  }
  return {};
}

namespace {

// Bounds on an episode summary's figures: an environment reports about ten, each named by a word
// or two; anything beyond is a broken or hostile sender.
constexpr int kMaxEpisodeFigures = 64;
constexpr size_t kMaxFigureName = 64;

v1::Tensor MakeTensor(v1::Tensor::DType dtype, const void* data,
                      const std::vector<int64_t>& shape) {
  v1::Tensor t;
  t.set_dtype(dtype);
  int64_t n = 1;
  for (int64_t d : shape) {
    t.add_shape(d);
    n *= d;
  }
  t.set_data(static_cast<const char*>(data), static_cast<size_t>(n) * DTypeSize(dtype));
  return t;
}

}  // namespace

v1::Tensor FloatTensor(const float* data, const std::vector<int64_t>& shape) {
  return MakeTensor(v1::Tensor::DTYPE_FLOAT32, data, shape);
}

v1::Tensor ByteTensor(const uint8_t* data, const std::vector<int64_t>& shape) {
  return MakeTensor(v1::Tensor::DTYPE_UINT8, data, shape);
}

int64_t Elements(const v1::Tensor& t) {
  int64_t n = 1;
  for (int64_t d : t.shape()) n *= d;
  return n;
}

Verdict CheckTensor(const v1::Tensor& t, v1::Tensor::DType dtype, const std::vector<int64_t>& shape,
                    const char* name) {
  if (t.dtype() != dtype) {
    return Reject(Rejection::kShape, std::string(name) + ": dtype " +
                                         v1::Tensor::DType_Name(t.dtype()) + ", expected " +
                                         v1::Tensor::DType_Name(dtype));
  }
  if (t.shape_size() != static_cast<int>(shape.size())) {
    return Reject(Rejection::kShape, std::string(name) + ": shape " + ShapeString(t) + " has " +
                                         std::to_string(t.shape_size()) + " dimensions, expected " +
                                         std::to_string(shape.size()));
  }
  int64_t n = 1;
  for (int i = 0; i < t.shape_size(); ++i) {
    int64_t d = t.shape(i);
    // Bounds first, so that a hostile shape cannot overflow the element count.
    if (d < 0 || d > (int64_t{1} << 31) || (shape[i] >= 0 && d != shape[i])) {
      return Reject(Rejection::kShape, std::string(name) + ": shape " + ShapeString(t) +
                                           " does not match the expected dimension " +
                                           std::to_string(i) + " of " + std::to_string(shape[i]));
    }
    if (d > 0 && n > (int64_t{1} << 32) / d) {
      return Reject(Rejection::kShape, std::string(name) + ": too many elements");
    }
    n *= d;
  }
  if (t.data().size() != static_cast<size_t>(n) * DTypeSize(dtype)) {
    return Reject(Rejection::kShape, std::string(name) + ": " + std::to_string(t.data().size()) +
                                         " bytes for shape " + ShapeString(t));
  }
  if (dtype == v1::Tensor::DTYPE_FLOAT32) {
    const char* bytes = t.data().data();
    for (int64_t i = 0; i < n; ++i) {
      float x;
      std::memcpy(&x, bytes + 4 * i, 4);
      if (!std::isfinite(x)) {
        return Reject(Rejection::kNonFinite,
                      std::string(name) + ": element " + std::to_string(i) + " is not finite");
      }
    }
  }
  return {};
}

std::vector<float> FloatValues(const v1::Tensor& t) {
  std::vector<float> out(t.data().size() / sizeof(float));
  std::memcpy(out.data(), t.data().data(), out.size() * sizeof(float));
  return out;
}

const float* FloatData(const v1::Tensor& t) {
  return reinterpret_cast<const float*>(t.data().data());
}

const uint8_t* ByteData(const v1::Tensor& t) {
  return reinterpret_cast<const uint8_t*>(t.data().data());
}

Verdict CheckSegment(const v1::TrajectorySegment& s, int observation_size, int action_size) {
  const auto F = v1::Tensor::DTYPE_FLOAT32;
  const auto U = v1::Tensor::DTYPE_UINT8;
  if (s.actions().shape_size() != 2) {
    return Reject(Rejection::kShape, "actions: expected [T, " + std::to_string(action_size) + "]");
  }
  const int64_t T = s.actions().shape(0);
  if (T < 1 || T > (int64_t{1} << 24)) {
    return Reject(Rejection::kShape, "actions: a segment needs 1 to 2^24 steps");
  }
  Verdict v;
  if (!(v = CheckTensor(s.observations(), F, {T + 1, observation_size}, "observations")).ok())
    return v;
  if (!(v = CheckTensor(s.actions(), F, {T, action_size}, "actions")).ok()) return v;
  if (!(v = CheckTensor(s.log_probs(), F, {T}, "log_probs")).ok()) return v;
  if (!(v = CheckTensor(s.rewards(), F, {T}, "rewards")).ok()) return v;
  if (!(v = CheckTensor(s.terminated(), U, {T}, "terminated")).ok()) return v;
  if (!(v = CheckTensor(s.truncated(), U, {T}, "truncated")).ok()) return v;
  const uint8_t* terminated = ByteData(s.terminated());
  const uint8_t* truncated = ByteData(s.truncated());
  int64_t inner_truncations = 0;
  for (int64_t t = 0; t < T; ++t) {
    if (terminated[t] > 1 || truncated[t] > 1 || (terminated[t] && truncated[t])) {
      return Reject(Rejection::kShape,
                    "step " + std::to_string(t) + ": terminated/truncated must be 0/1, not both");
    }
    if (truncated[t] && t < T - 1) ++inner_truncations;
  }
  if (!(v = CheckTensor(s.final_observations(), F, {inner_truncations, observation_size},
                        "final_observations"))
           .ok()) {
    return v;
  }
  if (s.policy_version() < 0) return Reject(Rejection::kShape, "negative policy version");
  for (const auto& e : s.episodes()) {
    if (!std::isfinite(e.episode_return()) || !std::isfinite(e.normalized_return())) {
      return Reject(Rejection::kNonFinite, "episode summary with a non-finite return");
    }
    if (e.length() < 0) return Reject(Rejection::kShape, "episode summary with a negative length");
    if (e.figures_size() > kMaxEpisodeFigures) {
      return Reject(Rejection::kShape, "episode summary with more than " +
                                           std::to_string(kMaxEpisodeFigures) + " figures");
    }
    for (const auto& f : e.figures()) {
      if (f.name().empty() || f.name().size() > kMaxFigureName) {
        return Reject(Rejection::kShape, "episode figure with an empty name or one longer than " +
                                             std::to_string(kMaxFigureName) + " bytes");
      }
      if (!std::isfinite(f.value())) {
        return Reject(Rejection::kNonFinite, "episode figure '" + f.name() + "' is not finite");
      }
    }
  }
  return {};
}

Verdict CheckSnapshot(const v1::PolicySnapshot& s) {
  const auto F = v1::Tensor::DTYPE_FLOAT32;
  const auto& net = s.network();
  if (net.observation_size() <= 0 || net.action_size() <= 0) {
    return Reject(Rejection::kShape, "network sizes must be positive");
  }
  Verdict v;
  if (!(v = CheckTensor(s.log_std(), F, {net.action_size()}, "log_std")).ok()) return v;
  if (!(v = CheckTensor(s.observation_mean(), F, {net.observation_size()}, "observation_mean"))
           .ok()) {
    return v;
  }
  if (!(v = CheckTensor(s.observation_var(), F, {net.observation_size()}, "observation_var"))
           .ok()) {
    return v;
  }
  for (float var : FloatValues(s.observation_var())) {
    if (var < 0) return Reject(Rejection::kShape, "observation_var: negative variance");
  }
  if (!std::isfinite(s.observation_count()) || s.observation_count() < 0) {
    return Reject(Rejection::kNonFinite, "observation_count must be finite and non-negative");
  }
  for (const auto& p : s.parameters()) {
    std::vector<int64_t> any(p.tensor().shape_size(), -1);
    if (!(v = CheckTensor(p.tensor(), F, any, p.name().c_str())).ok()) return v;
  }
  return {};
}

}  // namespace ragdoll::wire
