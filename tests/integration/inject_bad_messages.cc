// Sends malformed messages into a running broker: bytes that do not parse, another protocol
// version, a lying size header, a segment with NaN rewards and one of the wrong shape (the
// broker forwards the last two, which only the learner can check). Each must be counted and
// dropped while training goes on.
#include <zmq.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "common/wire.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s HOST TRAJECTORY_PORT RUN_ID\n", argv[0]);
    return 2;
  }
  using namespace ragdoll;
  const std::string endpoint = std::string("tcp://") + argv[1] + ":" + argv[2];
  const std::string run_id = argv[3];
  zmq::context_t context(1);
  zmq::socket_t push(context, zmq::socket_type::push);
  push.set(zmq::sockopt::linger, 2000);
  push.connect(endpoint);

  std::vector<std::string> messages;
  messages.push_back("\x05\x00\x00\x00garbage that is not a header");
  messages.push_back(std::string(3, '\x01'));
  {
    v1::Header h;
    h.set_protocol_version(99);
    h.set_kind(v1::KIND_TRAJECTORY);
    std::string header = h.SerializeAsString();
    std::string m(4, '\0');
    m[0] = static_cast<char>(header.size());
    messages.push_back(m + header);
  }
  {
    std::string m = wire::PackEmpty(v1::KIND_TRAJECTORY, run_id, "injector");
    messages.push_back(m + "extra bytes the header does not declare");
  }
  // Well-framed segments with bad numbers: T = 16 steps, 226 observations, 28 actions.
  const int T = 16, O = 226, A = 28;
  std::vector<float> obs((T + 1) * O, 0.0f), act(T * A, 0.0f), logp(T, -1.0f), rew(T, 0.5f);
  std::vector<uint8_t> flags(T, 0);
  auto segment = [&](int observation_size) {
    v1::TrajectorySegment s;
    s.set_actor_id("injector");
    *s.mutable_observations() = wire::FloatTensor(obs.data(), {T + 1, observation_size});
    *s.mutable_actions() = wire::FloatTensor(act.data(), {T, A});
    *s.mutable_log_probs() = wire::FloatTensor(logp.data(), {T});
    *s.mutable_rewards() = wire::FloatTensor(rew.data(), {T});
    *s.mutable_terminated() = wire::ByteTensor(flags.data(), {T});
    *s.mutable_truncated() = wire::ByteTensor(flags.data(), {T});
    *s.mutable_final_observations() = wire::FloatTensor(obs.data(), {0, observation_size});
    return s;
  };
  rew[3] = std::nanf("");
  messages.push_back(wire::Pack(v1::KIND_TRAJECTORY, run_id, "injector", segment(O)));
  rew[3] = 0.5f;
  messages.push_back(wire::Pack(v1::KIND_TRAJECTORY, run_id, "injector", segment(O - 1)));

  for (const auto& m : messages) push.send(zmq::buffer(m), zmq::send_flags::none);
  std::printf("injected %zu malformed messages into %s\n", messages.size(), endpoint.c_str());
  return 0;
}
