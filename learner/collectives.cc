#include "learner/collectives.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "learner/ppo.h"

namespace ragdoll::learner {
namespace {

class Lone : public Collectives {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void Sum(torch::Tensor&, const std::function<void()>&) override {}
  void Min(torch::Tensor&) override {}
  std::optional<std::string> FromRankZero(const std::function<std::string()>&) override {
    return std::nullopt;
  }

  void MergeStatistics(RunningStats& stats, const torch::Tensor& rows) override {
    torch::Tensor x = rows.contiguous();
    stats.Update(x.data_ptr<float>(), x.size(0));
  }

  Minibatches Split(int64_t samples, int64_t batch_size) override {
    Minibatches m;
    m.size = std::min(batch_size, samples);
    m.steps = samples / m.size;
    return m;
  }

  void StartEpoch(const torch::Tensor&, const torch::Tensor&) override {}

  torch::Tensor NormalizedAdvantages(const torch::Tensor& advantages, int64_t) override {
    return NormalizeAdvantages(advantages);
  }

  double Backward(torch::optim::Optimizer& optimizer, const torch::Tensor& loss,
                  double update_kl) override {
    optimizer.zero_grad();
    loss.backward();
    return update_kl;
  }
};

class Group : public Collectives {
 public:
  explicit Group(ReplicaGroup& group) : group_(group) {}

  int rank() const override { return group_.rank(); }
  int size() const override { return group_.size(); }
  void Sum(torch::Tensor& tensor, const std::function<void()>& meanwhile) override {
    group_.Sum(tensor, meanwhile);
  }
  void Min(torch::Tensor& tensor) override { group_.Min(tensor); }
  std::optional<std::string> FromRankZero(const std::function<std::string()>& state) override {
    std::string bytes = group_.Broadcast(group_.rank() == 0 ? state() : std::string());
    if (group_.rank() == 0) return std::nullopt;
    return bytes;
  }

  void MergeStatistics(RunningStats& stats, const torch::Tensor& rows) override {
    torch::Tensor x = rows.contiguous();
    // Each replica's own moments, then the union's (Chan et al.): its mean from the counts and
    // sums, then its squared deviations as each replica's plus its mean's distance from the
    // union's.
    const int size = stats.size();
    const double n = static_cast<double>(x.size(0));
    RunningStats::Moments local = RunningStats::BatchMoments(x.data_ptr<float>(), x.size(0), size);
    torch::Tensor sums = torch::empty({size + 1}, torch::kFloat64);
    double* s = sums.data_ptr<double>();
    s[0] = n;
    for (int j = 0; j < size; ++j) s[1 + j] = n * local.mean[j];
    group_.Sum(sums);
    const double count = s[0];
    if (count <= 0) return;
    std::vector<double> mean(size);
    for (int j = 0; j < size; ++j) mean[j] = s[1 + j] / count;
    torch::Tensor m2 = torch::empty({size}, torch::kFloat64);
    double* m = m2.data_ptr<double>();
    for (int j = 0; j < size; ++j) {
      const double d = local.mean[j] - mean[j];
      m[j] = local.m2[j] + n * d * d;
    }
    group_.Sum(m2);
    stats.Merge(count, mean, std::vector<double>(m, m + size));
  }

  // Every replica takes the same number of gradient steps. A replica that holds more than its share
  // (it took segments while waiting for the others) takes larger minibatches, and its gradient
  // weighs by its minibatch's part of the group's: the group's step is the mean over the union of
  // the replicas' minibatches, as one learner's would be.
  Minibatches Split(int64_t samples, int64_t batch_size) override {
    torch::Tensor steps = torch::tensor({samples / std::min(batch_size, samples)}, torch::kInt64);
    group_.Min(steps);
    split_.steps = steps.item<int64_t>();
    split_.size = samples / split_.steps;
    torch::Tensor group_size = torch::tensor({split_.size}, torch::kInt64);
    group_.Sum(group_size);
    split_.weight =
        static_cast<double>(split_.size) / static_cast<double>(group_size.item<int64_t>());
    return split_;
  }

  // The group's minibatch is the union of the replicas' ones: each step normalises its advantages
  // by that union's mean and (unbiased) standard deviation, as one learner would. The advantages
  // stay fixed through the update, so one collective per epoch carries every step's moments (sum,
  // sum of squares, count; float64).
  void StartEpoch(const torch::Tensor& advantages, const torch::Tensor& order) override {
    const int64_t steps = split_.steps, mb = split_.size;
    torch::Tensor a = advantages.index_select(0, order.slice(0, 0, steps * mb))
                          .to(torch::kFloat64)
                          .reshape({steps, mb});
    moments_ = torch::stack({a.sum(1), a.pow(2).sum(1),
                             torch::full({steps}, static_cast<double>(mb), torch::kFloat64)},
                            1)
                   .contiguous();
    group_.Sum(moments_);
  }

  torch::Tensor NormalizedAdvantages(const torch::Tensor& advantages, int64_t step) override {
    const double* m = moments_.data_ptr<double>() + 3 * step;
    const double n = m[2];
    const double mean = m[0] / n;
    const double var = n > 1 ? std::max(0.0, (m[1] - n * mean * mean) / (n - 1)) : 0.0;
    if (n > 1) return (advantages - mean) / (std::sqrt(var) + 1e-8);
    return advantages;
  }

  // One all-reduce per step, on the gradients in place: every gradient and this step's KL, each
  // weighted by this replica's share first, so their sum is the group's mean. Overlapping it with
  // the backward pass measured slower on pinned cores (docs/learner-scaling.md).
  double Backward(torch::optim::Optimizer& optimizer, const torch::Tensor& loss,
                  double update_kl) override {
    const std::vector<torch::Tensor>& params = optimizer.param_groups()[0].params();
    ViewGradientsInGroupBuffer(params);
    gradients_.zero_();
    (loss * split_.weight).backward();
    float* kl_slot = gradients_.data_ptr<float>() + gradients_.numel() - 1;
    *kl_slot = static_cast<float>(update_kl * split_.weight);
    group_.Sum(gradients_);
    return *kl_slot;
  }

 private:
  // Makes every parameter's gradient a view into gradients_ (re-made if a parameter was replaced),
  // so one all-reduce works on the gradients without copies.
  void ViewGradientsInGroupBuffer(const std::vector<torch::Tensor>& params) {
    int64_t total = 1;  // the KL slot
    for (const auto& p : params) total += p.numel();
    bool viewing = gradients_.defined() && gradients_.numel() == total;
    float* base = viewing ? gradients_.data_ptr<float>() : nullptr;
    int64_t offset = 0;
    for (const auto& p : params) {
      viewing = viewing && p.grad().defined() && p.grad().data_ptr<float>() == base + offset;
      offset += p.numel();
    }
    if (viewing) return;
    gradients_ = torch::zeros({total}, torch::kFloat32);
    offset = 0;
    for (const auto& p : params) {
      const int64_t n = p.numel();
      torch::Tensor view = gradients_.slice(0, offset, offset + n).view_as(p);
      if (p.grad().defined()) view.copy_(p.grad());
      p.mutable_grad() = view;
      offset += n;
    }
  }

  ReplicaGroup& group_;
  Minibatches split_;
  torch::Tensor moments_;  // this epoch's: [steps, 3] sum, sum of squares, count
  // Every gradient, then one slot for the step's KL: what the replicas all-reduce each step.
  torch::Tensor gradients_;
};

}  // namespace

std::unique_ptr<Collectives> LoneCollectives() { return std::make_unique<Lone>(); }

std::unique_ptr<Collectives> GroupCollectives(ReplicaGroup& group) {
  return std::make_unique<Group>(group);
}

}  // namespace ragdoll::learner
