// The wire protocol's codec: framing messages as (Header, payload) and validating what arrives.
// Serialisation only; sockets live with the processes that own them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ragdoll/v1/messages.pb.h"

namespace ragdoll::wire {

namespace v1 = ::ragdoll::v1;

constexpr uint32_t kProtocolVersion = v1::PROTOCOL_VERSION_CURRENT;

// Why a message was dropped; each has a counter at the broker and the learner.
enum class Rejection {
  kNone,
  kMalformed,     // frames missing, or bytes that do not parse
  kVersion,       // another protocol version
  kKind,          // unknown or unexpected kind
  kSizeMismatch,  // payload size differs from the header's
  kOversized,     // larger than the configured limit
  kShape,         // tensor dtype, shape or byte count inconsistent
  kNonFinite,     // NaN or Inf in a float tensor
  kRunId,         // from another run
};
const char* RejectionName(Rejection r);

// A decision with its reason, for logging.
struct Verdict {
  Rejection rejection = Rejection::kNone;
  std::string detail;
  bool ok() const { return rejection == Rejection::kNone; }
};

// A whole message as one frame: 4-byte little-endian header length, Header, payload.
std::string Pack(v1::Kind kind, const std::string& run_id, const std::string& sender,
                 const google::protobuf::MessageLite& payload, int64_t policy_version = 0);
// A message without a payload.
std::string PackEmpty(v1::Kind kind, const std::string& run_id, const std::string& sender);

// Parses and checks the header of a message of `size` bytes: framing, version, known kind,
// declared payload size, `max_message_bytes`. Does not look at the payload, which starts at
// *payload_offset.
Verdict ReadHeader(const void* data, size_t size, size_t max_message_bytes, v1::Header* header,
                   size_t* payload_offset);
// ReadHeader, then parses the payload into `message` (kMalformed when it does not parse).
Verdict ReadMessage(const void* data, size_t size, size_t max_message_bytes, v1::Header* header,
                    google::protobuf::MessageLite* message);

// Tensors.
v1::Tensor FloatTensor(const float* data, const std::vector<int64_t>& shape);
v1::Tensor ByteTensor(const uint8_t* data, const std::vector<int64_t>& shape);
int64_t Elements(const v1::Tensor& t);
// Checks dtype, shape (each dimension as given; -1 matches any size) and byte count, and for
// float tensors that every value is finite.
Verdict CheckTensor(const v1::Tensor& t, v1::Tensor::DType dtype, const std::vector<int64_t>& shape,
                    const char* name);
// Copies a checked float32 tensor's values (little-endian on the wire and on x86-64/ARM).
std::vector<float> FloatValues(const v1::Tensor& t);
const float* FloatData(const v1::Tensor& t);
const uint8_t* ByteData(const v1::Tensor& t);

// Full checks of the payloads that carry numbers, for the sizes the receiver expects.
Verdict CheckSegment(const v1::TrajectorySegment& s, int observation_size, int action_size);
Verdict CheckSnapshot(const v1::PolicySnapshot& s);

}  // namespace ragdoll::wire
