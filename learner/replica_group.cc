#include "learner/replica_group.h"

// Debian's libtorch is built with Gloo; its c10d headers show the Gloo process group only when
// told so (these definitions apply to this file alone).
#define USE_C10D_GLOO 1
#define USE_DISTRIBUTED 1
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>
#include <vector>

namespace ragdoll::learner {

struct ReplicaGroup::Impl {
  c10::intrusive_ptr<c10d::TCPStore> store;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> group;
};

ReplicaGroup::ReplicaGroup(const ReplicaGroupConfig& config)
    : impl_(std::make_unique<Impl>()), rank_(config.rank), size_(config.size) {
  if (config.size < 1 || config.rank < 0 || config.rank >= config.size) {
    throw std::invalid_argument("replica rank " + std::to_string(config.rank) +
                                " is outside a group of " + std::to_string(config.size));
  }
  try {
    c10d::TCPStoreOptions store;
    store.port = static_cast<std::uint16_t>(config.store_port);
    store.isServer = config.rank == 0;
    store.numWorkers = static_cast<std::size_t>(config.size);
    store.waitWorkers = true;
    store.timeout = config.timeout;
    impl_->store = c10::make_intrusive<c10d::TCPStore>(config.store_host, store);
    auto options = c10d::ProcessGroupGloo::Options::create(config.timeout);
    options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname(config.address));
    impl_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(impl_->store, config.rank,
                                                               config.size, options);
  } catch (const std::exception& e) {
    throw std::runtime_error("learner replica " + std::to_string(config.rank) + " of " +
                             std::to_string(config.size) + ": cannot join the group at " +
                             config.store_host + ":" + std::to_string(config.store_port) + " (" +
                             std::string(e.what()).substr(0, 300) + ")");
  }
}

ReplicaGroup::~ReplicaGroup() = default;

namespace {

// The first 300 characters of an exception that a Gloo worker thread made and libtorch rethrew
// here. Kept apart (and named in tests/sanitizers/tsan.supp): it reads only that exception,
// which libtorch hands over through synchronisation ThreadSanitizer cannot see.
[[gnu::noinline]] std::string GlooFailureText(const std::exception& e) {
  return std::string(e.what()).substr(0, 300);
}

// A replica polls a collective for up to this long before it blocks on it: a gradient step's
// all-reduce is shorter, and polled it took half the time it took blocked, probably because an
// idle core answers each of Gloo's messages late (docs/learner-scaling.md). Longer waits (a
// replica still filling its buffer) block after this, leaving the core to the actors.
constexpr auto kPollBeforeBlocking = std::chrono::milliseconds(10);

// `meanwhile`, when given, runs until the work completes instead of the polling.
void Run(const c10::intrusive_ptr<c10d::Work>& work, const char* what,
         const std::function<void()>& meanwhile = {}) {
  if (meanwhile) {
    while (!work->isCompleted()) meanwhile();
  }
  const auto until = std::chrono::steady_clock::now() + kPollBeforeBlocking;
  while (!work->isCompleted() && std::chrono::steady_clock::now() < until) {
    std::this_thread::yield();  // to Gloo's own threads, which may share this core
  }
  try {
    work->wait();
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("learner replica group: ") + what +
                             " failed; a replica stopped or cannot be reached (" +
                             GlooFailureText(e) + ")");
  }
}

}  // namespace

void ReplicaGroup::Sum(torch::Tensor& tensor, const std::function<void()>& meanwhile) {
  if (size_ == 1) return;
  std::vector<at::Tensor> tensors = {tensor};
  Run(impl_->group->allreduce(tensors), "sum", meanwhile);
}

void ReplicaGroup::Min(torch::Tensor& tensor) {
  if (size_ == 1) return;
  std::vector<at::Tensor> tensors = {tensor};
  c10d::AllreduceOptions options;
  options.reduceOp = c10d::ReduceOp::MIN;
  Run(impl_->group->allreduce(tensors, options), "min");
}

std::string ReplicaGroup::Broadcast(const std::string& bytes, int root) {
  if (size_ == 1) return bytes;
  torch::Tensor length = torch::tensor({static_cast<int64_t>(bytes.size())}, torch::kInt64);
  std::vector<at::Tensor> tensors = {length};
  c10d::BroadcastOptions options;
  options.rootRank = root;
  Run(impl_->group->broadcast(tensors, options), "broadcast");
  torch::Tensor data = torch::empty({length.item<int64_t>()}, torch::kUInt8);
  if (rank_ == root) std::memcpy(data.data_ptr<uint8_t>(), bytes.data(), bytes.size());
  tensors = {data};
  Run(impl_->group->broadcast(tensors, options), "broadcast");
  return std::string(reinterpret_cast<const char*>(data.data_ptr<uint8_t>()),
                     static_cast<size_t>(data.numel()));
}

}  // namespace ragdoll::learner
