// Seeds for fuzz_wire: the messages the system really sends, written one per file to DIR.
//   fuzz_wire_seeds DIR
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "common/wire.h"

int main(int argc, char** argv) {
  using namespace ragdoll;
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_wire_seeds DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir + "/" + name, std::ios::binary) << bytes;
  };
  const int T = 4, O = 197, A = 36;
  std::vector<float> obs((T + 1) * O, 0.5f), act(T * A, -0.25f), logp(T, -3.f), rew(T, 0.7f),
      fin(O, 0.1f);
  std::vector<uint8_t> term(T, 0), trunc(T, 0);
  term[2] = 1;
  v1::TrajectorySegment s;
  s.set_actor_id("host-actor-0");
  s.set_policy_version(12);
  *s.mutable_observations() = wire::FloatTensor(obs.data(), {T + 1, O});
  *s.mutable_actions() = wire::FloatTensor(act.data(), {T, A});
  *s.mutable_log_probs() = wire::FloatTensor(logp.data(), {T});
  *s.mutable_rewards() = wire::FloatTensor(rew.data(), {T});
  *s.mutable_terminated() = wire::ByteTensor(term.data(), {T});
  *s.mutable_truncated() = wire::ByteTensor(trunc.data(), {T});
  *s.mutable_final_observations() = wire::FloatTensor(fin.data(), {1, O});
  auto* e = s.add_episodes();
  e->set_episode_return(3.5);
  e->set_length(7);
  e->set_normalized_return(0.5);
  v1::Figure* f = e->add_figures();
  f->set_name("rotation");
  f->set_value(0.8);
  write("segment", wire::Pack(v1::KIND_TRAJECTORY, "run", "host-actor-0", s, 12));
  v1::PolicySnapshot snapshot;
  snapshot.set_version(12);
  write("snapshot", wire::Pack(v1::KIND_SNAPSHOT, "run", "learner", snapshot, 12));
  v1::ReplicaHello hello;
  hello.set_replica_id("host-learner-0");
  hello.set_replicas(2);
  hello.set_address("10.0.0.2");
  hello.set_store_port(5560);
  write("replica_hello", wire::Pack(v1::KIND_REPLICA_HELLO, "run", "host-learner-0", hello));
  write("heartbeat", wire::PackEmpty(v1::KIND_HEARTBEAT, "run", "host-actor-0"));
  return 0;
}
