#include "common/policy.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ragdoll {
namespace {

constexpr double kLogSqrt2Pi = 0.91893853320467274178;  // log(sqrt(2 pi))

torch::nn::AnyModule Activation(const std::string& name) {
  if (name == "relu") return torch::nn::AnyModule(torch::nn::ReLU());
  if (name == "elu") return torch::nn::AnyModule(torch::nn::ELU());
  return torch::nn::AnyModule(torch::nn::Tanh());
}

NetworkConfig ConfigOf(const v1::NetworkSpec& spec, double init_log_std) {
  NetworkConfig c;
  c.hidden_units.assign(spec.hidden_units().begin(), spec.hidden_units().end());
  c.activation = spec.activation();
  c.init_log_std = init_log_std;
  return c;
}

}  // namespace

torch::nn::Sequential MakeMlp(int inputs, int outputs, const NetworkConfig& config,
                              double output_gain) {
  torch::nn::Sequential net;
  int width = inputs;
  for (int units : config.hidden_units) {
    auto layer = torch::nn::Linear(width, units);
    torch::nn::init::orthogonal_(layer->weight, std::sqrt(2.0));
    torch::nn::init::zeros_(layer->bias);
    net->push_back(layer);
    net->push_back(Activation(config.activation));
    width = units;
  }
  auto out = torch::nn::Linear(width, outputs);
  torch::nn::init::orthogonal_(out->weight, output_gain);
  torch::nn::init::zeros_(out->bias);
  net->push_back(out);
  return net;
}

GaussianPolicyImpl::GaussianPolicyImpl(int observation_size, int action_size,
                                       const NetworkConfig& config)
    : observation_size_(observation_size), action_size_(action_size), config_(config) {
  if (config.activation != "tanh" && config.activation != "relu" && config.activation != "elu") {
    throw std::invalid_argument("unknown activation '" + config.activation + "'");
  }
  mean = register_module("mean", MakeMlp(observation_size, action_size, config, 0.01));
  log_std = register_parameter("log_std", torch::full({action_size}, config.init_log_std));
}

torch::Tensor GaussianPolicyImpl::forward(const torch::Tensor& observations) {
  return mean->forward(observations);
}

GaussianPolicyImpl::Evaluation GaussianPolicyImpl::Evaluate(const torch::Tensor& observations,
                                                            const torch::Tensor& actions) {
  torch::Tensor mu = forward(observations);
  torch::Tensor z = (actions - mu) * torch::exp(-log_std);
  torch::Tensor log_prob = (-0.5 * z * z - log_std - kLogSqrt2Pi).sum(-1);
  torch::Tensor entropy = (0.5 + kLogSqrt2Pi + log_std).sum().expand({observations.size(0)});
  return {mu, log_prob, entropy};
}

ValueNetworkImpl::ValueNetworkImpl(int observation_size, const NetworkConfig& config) {
  net = register_module("net", MakeMlp(observation_size, 1, config, 1.0));
}

torch::Tensor ValueNetworkImpl::forward(const torch::Tensor& observations) {
  return net->forward(observations).squeeze(-1);
}

v1::PolicySnapshot MakeSnapshot(GaussianPolicy& policy, const RunningStats& stats, int64_t version,
                                int64_t samples) {
  v1::PolicySnapshot s;
  s.set_version(version);
  s.set_samples(samples);
  auto* net = s.mutable_network();
  net->set_observation_size(policy->observation_size());
  net->set_action_size(policy->action_size());
  for (int units : policy->config().hidden_units) net->add_hidden_units(units);
  net->set_activation(policy->config().activation);
  torch::NoGradGuard no_grad;
  for (const auto& item : policy->mean->named_parameters()) {
    torch::Tensor t = item.value().detach().contiguous().to(torch::kFloat32);
    std::vector<int64_t> shape(t.sizes().begin(), t.sizes().end());
    auto* p = s.add_parameters();
    p->set_name(item.key());
    *p->mutable_tensor() = wire::FloatTensor(t.data_ptr<float>(), shape);
  }
  torch::Tensor log_std = policy->log_std.detach().contiguous();
  *s.mutable_log_std() = wire::FloatTensor(log_std.data_ptr<float>(), {policy->action_size()});
  std::vector<float> mean(stats.mean().begin(), stats.mean().end());
  std::vector<float> var(stats.var().begin(), stats.var().end());
  *s.mutable_observation_mean() = wire::FloatTensor(mean.data(), {stats.size()});
  *s.mutable_observation_var() = wire::FloatTensor(var.data(), {stats.size()});
  s.set_observation_count(stats.count());
  return s;
}

bool LoadSnapshotWeights(const v1::PolicySnapshot& snapshot, GaussianPolicy& policy) {
  auto params = policy->mean->named_parameters();
  if (snapshot.parameters_size() != static_cast<int>(params.size()) ||
      snapshot.network().action_size() != policy->action_size() ||
      snapshot.network().observation_size() != policy->observation_size()) {
    return false;
  }
  for (int i = 0; i < snapshot.parameters_size(); ++i) {
    const auto& p = snapshot.parameters(i);
    auto* target = params.find(p.name());
    if (!target || wire::Elements(p.tensor()) != target->numel() ||
        p.tensor().shape_size() != target->dim()) {
      return false;
    }
    for (int d = 0; d < target->dim(); ++d) {
      if (p.tensor().shape(d) != target->size(d)) return false;
    }
  }
  torch::NoGradGuard no_grad;
  for (const auto& p : snapshot.parameters()) {
    torch::Tensor& target = *params.find(p.name());
    std::memcpy(target.data_ptr<float>(), p.tensor().data().data(), p.tensor().data().size());
  }
  std::memcpy(policy->log_std.data_ptr<float>(), snapshot.log_std().data().data(),
              snapshot.log_std().data().size());
  return true;
}

GaussianPolicy PolicyFromSnapshot(const v1::PolicySnapshot& snapshot) {
  GaussianPolicy policy(snapshot.network().observation_size(), snapshot.network().action_size(),
                        ConfigOf(snapshot.network(), 0.0));
  if (!LoadSnapshotWeights(snapshot, policy)) {
    throw std::invalid_argument("snapshot parameters do not fit its network architecture");
  }
  policy->eval();
  return policy;
}

RunningStats StatsFromSnapshot(const v1::PolicySnapshot& snapshot) {
  std::vector<float> mean = wire::FloatValues(snapshot.observation_mean());
  std::vector<float> var = wire::FloatValues(snapshot.observation_var());
  return RunningStats(std::vector<double>(mean.begin(), mean.end()),
                      std::vector<double>(var.begin(), var.end()), snapshot.observation_count());
}

}  // namespace ragdoll
