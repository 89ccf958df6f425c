// Data-parallel learner replicas on libtorch's own distributed backend: a c10d TCPStore
// rendezvous (served by rank 0) and a ProcessGroupGloo over TCP. The Learner calls these
// collectives at fixed points of every update, so every replica applies the same steps and keeps
// the same weights. A replica that dies makes the others' next collective throw at once (Gloo
// sees the closed connection), or after `timeout` when it hangs. A replica polls each collective
// for up to 10 ms before it blocks on it (replica_group.cc says why).
#pragma once

#include <torch/torch.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>

namespace ragdoll::learner {

struct ReplicaGroupConfig {
  int rank = 0;
  int size = 1;
  std::string store_host = "127.0.0.1";  // rank 0's address: it serves the TCPStore
  int store_port = 5560;
  std::string address = "127.0.0.1";  // this replica's own address, for Gloo's connections
  std::chrono::milliseconds timeout{std::chrono::minutes(5)};
};

class ReplicaGroup {
 public:
  // Blocks until all `size` replicas have joined; throws std::runtime_error after `timeout`.
  explicit ReplicaGroup(const ReplicaGroupConfig& config);
  ~ReplicaGroup();
  ReplicaGroup(const ReplicaGroup&) = delete;
  ReplicaGroup& operator=(const ReplicaGroup&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }

  // In place over all replicas (contiguous float32, float64 or int64 tensors). Every replica
  // receives the same bits.
  // Sum calls `meanwhile`, when given, over and over until every replica has joined (each call
  // should return within a few milliseconds): a replica waiting for the others keeps working.
  void Sum(torch::Tensor& tensor, const std::function<void()>& meanwhile = {});
  void Min(torch::Tensor& tensor);
  // Rank `root`'s bytes, on every replica.
  std::string Broadcast(const std::string& bytes, int root = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int rank_, size_;
};

}  // namespace ragdoll::learner
