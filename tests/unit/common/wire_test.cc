#include "common/wire.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace ragdoll::wire {
namespace {

using ::testing::HasSubstr;

constexpr size_t kLimit = 1 << 20;
constexpr int kObs = 3;
constexpr int kAct = 2;
// Where a tensor of no elements points.
constexpr float kNone = 0.0f;

// The framing written out independently of Pack: 4-byte little-endian header length, the
// Header, then the payload.
std::string Frame(const v1::Header& header, const std::string& payload) {
  const std::string h = header.SerializeAsString();
  const uint32_t n = static_cast<uint32_t>(h.size());
  std::string out;
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((n >> (8 * i)) & 0xff));
  return out + h + payload;
}

v1::Header ValidHeader(size_t payload_bytes) {
  v1::Header h;
  h.set_protocol_version(kProtocolVersion);
  h.set_kind(v1::KIND_HEARTBEAT);
  h.set_run_id("run-1");
  h.set_sender("actor-0");
  h.set_payload_bytes(payload_bytes);
  return h;
}

Verdict Read(const std::string& message, v1::Header* header, size_t* offset,
             size_t limit = kLimit) {
  return ReadHeader(message.data(), message.size(), limit, header, offset);
}

Verdict Read(const std::string& message, size_t limit = kLimit) {
  v1::Header header;
  size_t offset = 0;
  return Read(message, &header, &offset, limit);
}

// T = 5 steps of a 3-number observation and 2-number action: step 1 truncated mid-segment (one
// final observation), step 2 terminated, step 4 (the last) truncated, which bootstraps from
// observations[T] and needs no final observation.
struct SegmentData {
  std::vector<float> observations, actions, log_probs, rewards, final_observations;
  std::vector<uint8_t> terminated, truncated;
  int64_t T = 5;
  SegmentData() {
    for (int i = 0; i < (T + 1) * kObs; ++i) observations.push_back(0.25f * i - 2.0f);
    for (int i = 0; i < T * kAct; ++i) actions.push_back(i % 2 ? -0.1f * i : 0.3f * i);
    log_probs = {-1.5f, -2.25f, -0.75f, -3.0f, -1.0f};
    rewards = {0.9f, 0.8f, 0.0f, 0.7f, 0.95f};
    terminated = {0, 0, 1, 0, 0};
    truncated = {0, 1, 0, 0, 1};
    final_observations = {9.0f, 8.5f, -7.25f};
  }
  v1::TrajectorySegment Build() const {
    v1::TrajectorySegment s;
    s.set_actor_id("actor-7");
    s.set_env_index(3);
    s.set_policy_version(42);
    *s.mutable_observations() = FloatTensor(observations.data(), {T + 1, kObs});
    *s.mutable_actions() = FloatTensor(actions.data(), {T, kAct});
    *s.mutable_log_probs() = FloatTensor(log_probs.data(), {T});
    *s.mutable_rewards() = FloatTensor(rewards.data(), {T});
    *s.mutable_terminated() = ByteTensor(terminated.data(), {T});
    *s.mutable_truncated() = ByteTensor(truncated.data(), {T});
    *s.mutable_final_observations() = FloatTensor(final_observations.data(), {1, kObs});
    v1::EpisodeSummary* e = s.add_episodes();
    e->set_episode_return(12.5);
    e->set_length(40);
    e->set_normalized_return(0.625);
    e->set_fell(true);
    return s;
  }
};

struct SnapshotData {
  std::vector<float> weight, bias, log_std, mean, var;
  SnapshotData() {
    for (int i = 0; i < 4 * kObs; ++i) weight.push_back(0.01f * i - 0.05f);
    bias = {0.1f, -0.2f, 0.3f, -0.4f};
    log_std = {-0.5f, -1.0f};
    mean = {0.0f, 1.5f, -2.0f};
    var = {1.0f, 0.25f, 4.0f};
  }
  v1::PolicySnapshot Build() const {
    v1::PolicySnapshot s;
    s.set_version(17);
    s.set_samples(123456);
    s.set_observation_count(1000.0);
    s.mutable_network()->set_observation_size(kObs);
    s.mutable_network()->set_action_size(kAct);
    s.mutable_network()->add_hidden_units(4);
    s.mutable_network()->set_activation("tanh");
    v1::NamedTensor* w = s.add_parameters();
    w->set_name("0.weight");
    *w->mutable_tensor() = FloatTensor(weight.data(), {4, kObs});
    v1::NamedTensor* b = s.add_parameters();
    b->set_name("0.bias");
    *b->mutable_tensor() = FloatTensor(bias.data(), {4});
    *s.mutable_log_std() = FloatTensor(log_std.data(), {kAct});
    *s.mutable_observation_mean() = FloatTensor(mean.data(), {kObs});
    *s.mutable_observation_var() = FloatTensor(var.data(), {kObs});
    return s;
  }
};

// ---------------------------------------------------------------------------------------------
// Round trips

TEST(Wire, PackThenReadHeaderRoundTrips) {
  v1::Heartbeat beat;
  beat.set_actor_id("actor-3");
  beat.set_policy_version(9);
  beat.set_samples(4096);
  const std::string message = Pack(v1::KIND_HEARTBEAT, "run-1", "actor-3", beat, 9);

  v1::Header header;
  size_t offset = 0;
  const Verdict v = Read(message, &header, &offset);
  ASSERT_TRUE(v.ok()) << v.detail;
  EXPECT_EQ(header.protocol_version(), kProtocolVersion);
  EXPECT_EQ(header.kind(), v1::KIND_HEARTBEAT);
  EXPECT_EQ(header.run_id(), "run-1");
  EXPECT_EQ(header.sender(), "actor-3");
  EXPECT_EQ(header.policy_version(), 9);
  EXPECT_EQ(header.payload_bytes(), beat.ByteSizeLong());
  // The layout the protocol documents: length prefix, header, payload.
  EXPECT_EQ(offset, 4 + header.ByteSizeLong());
  EXPECT_EQ(message.size(), offset + beat.ByteSizeLong());
  uint32_t prefix = 0;
  for (int i = 0; i < 4; ++i)
    prefix |= static_cast<uint32_t>(static_cast<uint8_t>(message[i])) << (8 * i);
  EXPECT_EQ(prefix, header.ByteSizeLong());

  v1::Heartbeat back;
  ASSERT_TRUE(
      back.ParseFromArray(message.data() + offset, static_cast<int>(message.size() - offset)));
  EXPECT_EQ(back.actor_id(), "actor-3");
  EXPECT_EQ(back.policy_version(), 9);
  EXPECT_EQ(back.samples(), 4096);

  // The same message framed by hand reads the same way.
  v1::Header again;
  const Verdict by_hand = Read(Frame(header, beat.SerializeAsString()), &again, &offset);
  ASSERT_TRUE(by_hand.ok()) << by_hand.detail;
  EXPECT_EQ(again.sender(), "actor-3");
}

TEST(Wire, PackEmptyHasNoPayload) {
  const std::string message = PackEmpty(v1::KIND_NO_SNAPSHOT, "run-1", "broker");
  v1::Header header;
  size_t offset = 0;
  const Verdict v = Read(message, &header, &offset);
  ASSERT_TRUE(v.ok()) << v.detail;
  EXPECT_EQ(header.kind(), v1::KIND_NO_SNAPSHOT);
  EXPECT_EQ(header.sender(), "broker");
  EXPECT_EQ(header.payload_bytes(), 0u);
  EXPECT_EQ(offset, message.size());
}

TEST(Wire, TrajectorySegmentRoundTrips) {
  const SegmentData d;
  const std::string message =
      Pack(v1::KIND_TRAJECTORY, "run-1", "actor-7", d.Build(), /*policy_version=*/42);
  v1::Header header;
  v1::TrajectorySegment s;
  const Verdict read = ReadMessage(message.data(), message.size(), kLimit, &header, &s);
  ASSERT_TRUE(read.ok()) << read.detail;
  EXPECT_EQ(header.kind(), v1::KIND_TRAJECTORY);
  EXPECT_EQ(header.policy_version(), 42);
  const Verdict v = CheckSegment(s, kObs, kAct);
  ASSERT_TRUE(v.ok()) << v.detail;

  EXPECT_EQ(s.actor_id(), "actor-7");
  EXPECT_EQ(s.env_index(), 3);
  EXPECT_EQ(s.policy_version(), 42);
  EXPECT_EQ(FloatValues(s.observations()), d.observations);
  EXPECT_EQ(FloatValues(s.actions()), d.actions);
  EXPECT_EQ(FloatValues(s.log_probs()), d.log_probs);
  EXPECT_EQ(FloatValues(s.rewards()), d.rewards);
  EXPECT_EQ(FloatValues(s.final_observations()), d.final_observations);
  EXPECT_EQ(Elements(s.observations()), (d.T + 1) * kObs);
  EXPECT_EQ(FloatData(s.rewards())[4], 0.95f);
  const uint8_t* term = ByteData(s.terminated());
  const uint8_t* trunc = ByteData(s.truncated());
  EXPECT_EQ(std::vector<uint8_t>(term, term + d.T), d.terminated);
  EXPECT_EQ(std::vector<uint8_t>(trunc, trunc + d.T), d.truncated);
  ASSERT_EQ(s.episodes_size(), 1);
  EXPECT_EQ(s.episodes(0).episode_return(), 12.5);
  EXPECT_EQ(s.episodes(0).length(), 40);
  EXPECT_TRUE(s.episodes(0).fell());
}

TEST(Wire, PolicySnapshotRoundTrips) {
  const SnapshotData d;
  const std::string message =
      Pack(v1::KIND_SNAPSHOT, "run-1", "learner", d.Build(), /*policy_version=*/17);
  v1::Header header;
  v1::PolicySnapshot s;
  const Verdict read = ReadMessage(message.data(), message.size(), kLimit, &header, &s);
  ASSERT_TRUE(read.ok()) << read.detail;
  EXPECT_EQ(header.kind(), v1::KIND_SNAPSHOT);
  EXPECT_EQ(header.policy_version(), 17);
  const Verdict v = CheckSnapshot(s);
  ASSERT_TRUE(v.ok()) << v.detail;

  EXPECT_EQ(s.version(), 17);
  EXPECT_EQ(s.samples(), 123456);
  EXPECT_EQ(s.observation_count(), 1000.0);
  EXPECT_EQ(s.network().observation_size(), kObs);
  EXPECT_EQ(s.network().action_size(), kAct);
  EXPECT_EQ(s.network().activation(), "tanh");
  ASSERT_EQ(s.parameters_size(), 2);
  EXPECT_EQ(s.parameters(0).name(), "0.weight");
  EXPECT_EQ(s.parameters(0).tensor().shape(0), 4);
  EXPECT_EQ(s.parameters(0).tensor().shape(1), kObs);
  EXPECT_EQ(FloatValues(s.parameters(0).tensor()), d.weight);
  EXPECT_EQ(FloatValues(s.parameters(1).tensor()), d.bias);
  EXPECT_EQ(FloatValues(s.log_std()), d.log_std);
  EXPECT_EQ(FloatValues(s.observation_mean()), d.mean);
  EXPECT_EQ(FloatValues(s.observation_var()), d.var);
}

// ---------------------------------------------------------------------------------------------
// Rejections: each names its reason and the offending part.

TEST(WireRejects, MalformedHeaderBytes) {
  const std::string payload = "abc";
  // Shorter than the length prefix.
  Verdict v = Read(std::string("\x01\x00", 2));
  EXPECT_EQ(v.rejection, Rejection::kMalformed);
  EXPECT_THAT(v.detail, HasSubstr("length prefix"));
  // A header length beyond the end of the message.
  v = Read(std::string("\x40\x00\x00\x00", 4) + payload);
  EXPECT_EQ(v.rejection, Rejection::kMalformed);
  EXPECT_THAT(v.detail, HasSubstr("header length"));
  // Three header bytes that are not a protobuf message (a field tag whose varint never ends).
  v = Read(std::string("\x03\x00\x00\x00\xff\xff\xff", 7) + payload);
  EXPECT_EQ(v.rejection, Rejection::kMalformed);
  EXPECT_THAT(v.detail, HasSubstr("header"));
  EXPECT_STREQ(RejectionName(v.rejection), "malformed");
}

// Found by fuzz_wire: protobuf logs a line for every string with invalid UTF-8 it parses, so a
// sender could flood the log of whoever reads its messages. The messages are rejected; the log
// keeps at most one such line a minute.
TEST(WireRejects, InvalidUtf8IsRejectedWithoutFloodingTheLog) {
  v1::Header header = ValidHeader(0);
  header.set_run_id("ok");
  std::string message = Frame(header, "");
  const size_t at = message.find("ok");
  ASSERT_NE(at, std::string::npos);
  message[at] = '\xff';  // run_id is no longer UTF-8
  ::testing::internal::CaptureStderr();
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(Read(message).rejection, Rejection::kMalformed);
  const std::string log = ::testing::internal::GetCapturedStderr();
  int lines = 0;
  for (char c : log) lines += c == '\n';
  EXPECT_LE(lines, 1) << log;
}

TEST(WireRejects, PayloadThatDoesNotParse) {
  const std::string garbage("\xff\xff\xff", 3);
  v1::Header header = ValidHeader(garbage.size());
  header.set_kind(v1::KIND_TRAJECTORY);
  const std::string message = Frame(header, garbage);
  ASSERT_TRUE(Read(message).ok());
  v1::TrajectorySegment s;
  const Verdict v = ReadMessage(message.data(), message.size(), kLimit, &header, &s);
  EXPECT_EQ(v.rejection, Rejection::kMalformed);
  EXPECT_THAT(v.detail, HasSubstr("TrajectorySegment"));
}

TEST(WireRejects, WrongProtocolVersion) {
  v1::Header header = ValidHeader(0);
  ASSERT_TRUE(Read(Frame(header, "")).ok());
  header.set_protocol_version(kProtocolVersion + 1);
  Verdict v = Read(Frame(header, ""));
  EXPECT_EQ(v.rejection, Rejection::kVersion);
  EXPECT_THAT(v.detail, HasSubstr("protocol version " + std::to_string(kProtocolVersion + 1)));
  header.clear_protocol_version();
  v = Read(Frame(header, ""));
  EXPECT_EQ(v.rejection, Rejection::kVersion);
  EXPECT_THAT(v.detail, HasSubstr("protocol version 0"));
}

TEST(WireRejects, UnknownKind) {
  v1::Header header = ValidHeader(0);
  header.set_kind(v1::KIND_UNSPECIFIED);
  Verdict v = Read(Frame(header, ""));
  EXPECT_EQ(v.rejection, Rejection::kKind);
  EXPECT_THAT(v.detail, HasSubstr("kind 0"));
  // A kind from a newer schema (proto3 enums keep unknown values).
  header.set_kind(static_cast<v1::Kind>(99));
  v = Read(Frame(header, ""));
  EXPECT_EQ(v.rejection, Rejection::kKind);
  EXPECT_THAT(v.detail, HasSubstr("kind 99"));
}

TEST(WireRejects, PayloadSizeDifferentFromHeader) {
  v1::Heartbeat beat;
  beat.set_actor_id("actor-3");
  const std::string message = Pack(v1::KIND_HEARTBEAT, "run-1", "actor-3", beat);
  const size_t declared = beat.ByteSizeLong();
  // One byte too many, one too few.
  Verdict v = Read(message + "x");
  EXPECT_EQ(v.rejection, Rejection::kSizeMismatch);
  EXPECT_THAT(v.detail, HasSubstr("header says " + std::to_string(declared) + " payload bytes"));
  EXPECT_THAT(v.detail, HasSubstr(std::to_string(declared + 1)));
  v = Read(message.substr(0, message.size() - 1));
  EXPECT_EQ(v.rejection, Rejection::kSizeMismatch);
  EXPECT_THAT(v.detail, HasSubstr("message has " + std::to_string(declared - 1)));
}

TEST(WireRejects, OversizedMessage) {
  const SnapshotData d;
  const std::string message = Pack(v1::KIND_SNAPSHOT, "run-1", "learner", d.Build());
  EXPECT_TRUE(Read(message, /*limit=*/message.size()).ok());
  const Verdict v = Read(message, /*limit=*/message.size() - 1);
  EXPECT_EQ(v.rejection, Rejection::kOversized);
  EXPECT_THAT(v.detail, HasSubstr(std::to_string(message.size()) + " bytes"));
  EXPECT_THAT(v.detail, HasSubstr("limit " + std::to_string(message.size() - 1)));
}

TEST(WireRejects, TensorShapeDtypeAndByteCount) {
  const SegmentData d;
  {
    // Observations of the wrong width.
    v1::TrajectorySegment s = d.Build();
    *s.mutable_observations() = FloatTensor(d.observations.data(), {d.T + 1, kObs - 1});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("observations"));
  }
  {
    // Observations without the bootstrap row.
    v1::TrajectorySegment s = d.Build();
    *s.mutable_observations() = FloatTensor(d.observations.data(), {d.T, kObs});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("observations"));
  }
  {
    // Rewards whose bytes were cut short: the shape says 5 floats, the data holds 19 bytes.
    v1::TrajectorySegment s = d.Build();
    s.mutable_rewards()->mutable_data()->pop_back();
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("rewards"));
    EXPECT_THAT(v.detail, HasSubstr("19 bytes"));
  }
  {
    // Terminated flags sent as float32.
    v1::TrajectorySegment s = d.Build();
    const std::vector<float> flags(d.T, 0.0f);
    *s.mutable_terminated() = FloatTensor(flags.data(), {d.T});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("terminated"));
    EXPECT_THAT(v.detail, HasSubstr("DTYPE_FLOAT32"));
  }
  {
    // log_probs one step short.
    v1::TrajectorySegment s = d.Build();
    *s.mutable_log_probs() = FloatTensor(d.log_probs.data(), {d.T - 1});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("log_probs"));
  }
  {
    // A snapshot whose log_std does not match the network's action size.
    const SnapshotData sd;
    v1::PolicySnapshot s = sd.Build();
    s.mutable_network()->set_action_size(kAct + 1);
    const Verdict v = CheckSnapshot(s);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("log_std"));
  }
  {
    // A snapshot parameter with truncated bytes names the parameter.
    const SnapshotData sd;
    v1::PolicySnapshot s = sd.Build();
    s.mutable_parameters(1)->mutable_tensor()->mutable_data()->resize(4 * 3);
    const Verdict v = CheckSnapshot(s);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("0.bias"));
  }
}

TEST(WireRejects, NonFiniteValues) {
  const SegmentData d;
  {
    SegmentData bad = d;
    bad.rewards[2] = std::numeric_limits<float>::quiet_NaN();
    const Verdict v = CheckSegment(bad.Build(), kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("rewards"));
    EXPECT_THAT(v.detail, HasSubstr("element 2"));
  }
  {
    SegmentData bad = d;
    bad.observations[7] = std::numeric_limits<float>::infinity();
    const Verdict v = CheckSegment(bad.Build(), kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("observations"));
    EXPECT_THAT(v.detail, HasSubstr("element 7"));
  }
  {
    SegmentData bad = d;
    bad.final_observations[1] = -std::numeric_limits<float>::infinity();
    const Verdict v = CheckSegment(bad.Build(), kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("final_observations"));
  }
  {
    SnapshotData bad;
    bad.log_std[1] = std::numeric_limits<float>::infinity();
    const Verdict v = CheckSnapshot(bad.Build());
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("log_std"));
  }
  {
    SnapshotData bad;
    bad.weight[5] = std::numeric_limits<float>::quiet_NaN();
    const Verdict v = CheckSnapshot(bad.Build());
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("0.weight"));
    EXPECT_THAT(v.detail, HasSubstr("element 5"));
  }
  {
    // An episode summary travels as doubles, checked too.
    v1::TrajectorySegment s = d.Build();
    s.mutable_episodes(0)->set_episode_return(std::numeric_limits<double>::quiet_NaN());
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("episode summary"));
    EXPECT_THAT(v.detail, HasSubstr("return"));
  }
}

// Episode figures travel by name: finite values, a bounded count and bounded names.
TEST(WireRejects, BadEpisodeFigures) {
  const SegmentData d;
  auto with_figure = [&](const std::string& name, double value) {
    v1::TrajectorySegment s = d.Build();
    v1::Figure* f = s.mutable_episodes(0)->add_figures();
    f->set_name(name);
    f->set_value(value);
    return s;
  };
  EXPECT_TRUE(CheckSegment(with_figure("speed_error", 0.25), kObs, kAct).ok());
  {
    const Verdict v = CheckSegment(
        with_figure("speed_error", std::numeric_limits<double>::infinity()), kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kNonFinite);
    EXPECT_THAT(v.detail, HasSubstr("'speed_error'"));
  }
  EXPECT_EQ(CheckSegment(with_figure("", 1), kObs, kAct).rejection, Rejection::kShape);
  EXPECT_EQ(CheckSegment(with_figure(std::string(65, 'x'), 1), kObs, kAct).rejection,
            Rejection::kShape);
  EXPECT_TRUE(CheckSegment(with_figure(std::string(64, 'x'), 1), kObs, kAct).ok());
  v1::TrajectorySegment many = d.Build();
  for (int i = 0; i < 65; ++i) {
    v1::Figure* f = many.mutable_episodes(0)->add_figures();
    f->set_name("f" + std::to_string(i));
    f->set_value(i);
  }
  const Verdict v = CheckSegment(many, kObs, kAct);
  EXPECT_EQ(v.rejection, Rejection::kShape);
  EXPECT_THAT(v.detail, HasSubstr("more than 64 figures"));
}

TEST(WireRejects, StepBothTerminatedAndTruncated) {
  SegmentData d;
  d.truncated[2] = 1;  // step 2 is already terminated; now also an inner truncation
  d.final_observations = {9.0f, 8.5f, -7.25f, 1.0f, 2.0f, 3.0f};
  v1::TrajectorySegment s = d.Build();
  *s.mutable_final_observations() = FloatTensor(d.final_observations.data(), {2, kObs});
  const Verdict v = CheckSegment(s, kObs, kAct);
  EXPECT_EQ(v.rejection, Rejection::kShape);
  EXPECT_THAT(v.detail, HasSubstr("step 2"));
  EXPECT_THAT(v.detail, HasSubstr("terminated"));
  EXPECT_THAT(v.detail, HasSubstr("truncated"));
}

TEST(WireRejects, FlagThatIsNotZeroOrOne) {
  SegmentData d;
  d.terminated[3] = 2;
  const Verdict v = CheckSegment(d.Build(), kObs, kAct);
  EXPECT_EQ(v.rejection, Rejection::kShape);
  EXPECT_THAT(v.detail, HasSubstr("step 3"));
}

TEST(WireRejects, FinalObservationsNotMatchingInnerTruncations) {
  const SegmentData d;
  {
    // One inner truncation (step 1) but no final observation.
    v1::TrajectorySegment s = d.Build();
    *s.mutable_final_observations() = FloatTensor(&kNone, {0, kObs});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("final_observations"));
  }
  {
    // Two final observations: the truncation at the last step must not have one.
    const std::vector<float> two = {1, 2, 3, 4, 5, 6};
    v1::TrajectorySegment s = d.Build();
    *s.mutable_final_observations() = FloatTensor(two.data(), {2, kObs});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_EQ(v.rejection, Rejection::kShape);
    EXPECT_THAT(v.detail, HasSubstr("final_observations"));
  }
  {
    // Without the inner truncation, zero final observations is right.
    SegmentData only_last = d;
    only_last.truncated[1] = 0;
    v1::TrajectorySegment s = only_last.Build();
    *s.mutable_final_observations() = FloatTensor(&kNone, {0, kObs});
    const Verdict v = CheckSegment(s, kObs, kAct);
    EXPECT_TRUE(v.ok()) << v.detail;
  }
}

}  // namespace
}  // namespace ragdoll::wire
