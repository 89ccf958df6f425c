#include "exports/onnx_export.h"

#include <gtest/gtest.h>
#include <torch/torch.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "common/running_stats.h"

namespace ragdoll::exports {
namespace {
namespace fs = std::filesystem;

constexpr int kObs = 12, kAct = 5;

// Observation statistics far from (0, 1): column j has mean 3 j - 10 and a standard deviation
// from 0.01 to 50, and the last column is constant (variance 0, so any other value normalises
// beyond the clip).
RunningStats SkewedStats(std::mt19937& rng) {
  RunningStats stats(kObs);
  std::normal_distribution<float> unit(0.0f, 1.0f);
  std::vector<float> batch(500 * kObs);
  for (int i = 0; i < 500; ++i) {
    for (int j = 0; j < kObs; ++j) {
      const float spread = j == kObs - 1 ? 0.0f : 0.01f * std::pow(5000.0f, j / (kObs - 2.0f));
      batch[i * kObs + j] = 3.0f * j - 10.0f + spread * unit(rng);
    }
  }
  stats.Update(batch.data(), 500);
  return stats;
}

torch::Tensor TensorOf(const onnx::TensorProto& t) {
  std::vector<int64_t> dims(t.dims().begin(), t.dims().end());
  std::vector<float> values(t.float_data().begin(), t.float_data().end());
  return torch::from_blob(values.data(), dims, torch::kFloat32).clone();
}

// Runs the graph op by op with libtorch: every op the exporter may write, nothing else.
std::map<std::string, torch::Tensor> RunGraph(const onnx::ModelProto& model,
                                              const torch::Tensor& x) {
  std::map<std::string, torch::Tensor> values;
  for (const auto& t : model.graph().initializer()) values[t.name()] = TensorOf(t);
  values[model.graph().input(0).name()] = x;
  for (const auto& node : model.graph().node()) {
    std::vector<torch::Tensor> in;
    for (const auto& name : node.input()) {
      EXPECT_TRUE(values.count(name)) << node.op_type() << " reads unknown " << name;
      in.push_back(values[name]);
    }
    std::map<std::string, onnx::AttributeProto> attributes;
    for (const auto& a : node.attribute()) attributes[a.name()] = a;
    const std::string& op = node.op_type();
    torch::Tensor y;
    if (op == "Sub") {
      y = in[0] - in[1];
    } else if (op == "Mul") {
      y = in[0] * in[1];
    } else if (op == "Add") {
      y = in[0] + in[1];
    } else if (op == "Clip") {
      y = torch::clamp(in[0], in[1].item<float>(), in[2].item<float>());
    } else if (op == "Gemm") {
      EXPECT_EQ(attributes.count("alpha") + attributes.count("beta") + attributes.count("transA"),
                0u);
      const bool trans_b = attributes.count("transB") && attributes["transB"].i() == 1;
      y = torch::matmul(in[0], trans_b ? in[1].t() : in[1]) + in[2];
    } else if (op == "Tanh") {
      y = torch::tanh(in[0]);
    } else if (op == "Relu") {
      y = torch::relu(in[0]);
    } else if (op == "Elu") {
      y = torch::elu(in[0], attributes["alpha"].f());
    } else {
      ADD_FAILURE() << "unexpected op " << op;
      return values;
    }
    values[node.output(0)] = y;
  }
  return values;
}

class OnnxExportTest : public ::testing::TestWithParam<std::string> {
 protected:
  OnnxExportTest() : rng_(7) {
    torch::manual_seed(11);
    NetworkConfig net;
    net.hidden_units = {16, 8};
    net.activation = GetParam();
    policy_ = GaussianPolicy(kObs, kAct, net);
    // Weights large enough that the outputs are not near zero (MakeMlp scales the last layer to
    // 0.01 for training).
    torch::NoGradGuard no_grad;
    for (auto& p : policy_->parameters()) p.normal_(0.0, 0.5);
    stats_ = SkewedStats(rng_);
    snapshot_ = MakeSnapshot(policy_, stats_, 42, 12345);
    value_.critic = ValueNetwork(kObs, net);
    value_.scale = 2.5;
    value_.offset = -1.25;
    metadata_ = {{"policy_version", "42"}, {"clip", "stand"}};
  }

  // Raw observations around the statistics, some far out (the normaliser clips those).
  torch::Tensor Observations(int rows) {
    std::vector<float> x(rows * kObs);
    std::normal_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < kObs; ++j) {
        const double spread = std::sqrt(stats_.var()[j]) + 0.001;
        x[i * kObs + j] = static_cast<float>(stats_.mean()[j] + 4.0 * spread * unit(rng_));
      }
    }
    return torch::from_blob(x.data(), {rows, kObs}).clone();
  }

  std::mt19937 rng_;
  GaussianPolicy policy_{nullptr};
  RunningStats stats_;
  v1::PolicySnapshot snapshot_;
  ValueHead value_;
  std::map<std::string, std::string> metadata_;
};

TEST_P(OnnxExportTest, CheckerAcceptsTheGraphWithItsNamesAndShapes) {
  onnx::ModelProto model = BuildPolicyModel(snapshot_, &value_, metadata_);
  EXPECT_NO_THROW(CheckModel(model));
  EXPECT_EQ(model.ir_version(), 7);
  ASSERT_EQ(model.opset_import_size(), 1);
  EXPECT_EQ(model.opset_import(0).version(), 13);
  EXPECT_EQ(model.model_version(), 42);
  EXPECT_EQ(model.producer_name(), "ragdoll");
  std::map<std::string, std::string> props;
  for (const auto& p : model.metadata_props()) props[p.key()] = p.value();
  EXPECT_EQ(props["policy_version"], "42");
  EXPECT_EQ(props["clip"], "stand");

  const onnx::GraphProto& g = model.graph();
  ASSERT_EQ(g.input_size(), 1);
  ASSERT_EQ(g.output_size(), 2);
  auto shape_of = [](const onnx::ValueInfoProto& v) {
    std::vector<std::string> dims;
    for (const auto& d : v.type().tensor_type().shape().dim()) {
      dims.push_back(d.has_dim_param() ? d.dim_param() : std::to_string(d.dim_value()));
    }
    return dims;
  };
  EXPECT_EQ(g.input(0).name(), "observation");
  EXPECT_EQ(shape_of(g.input(0)), (std::vector<std::string>{"batch", "12"}));
  EXPECT_EQ(g.output(0).name(), "action");
  EXPECT_EQ(shape_of(g.output(0)), (std::vector<std::string>{"batch", "5"}));
  EXPECT_EQ(g.output(1).name(), "value");
  EXPECT_EQ(shape_of(g.output(1)), (std::vector<std::string>{"batch", "1"}));
  for (const auto& node : g.node()) {
    EXPECT_TRUE(node.domain().empty()) << node.op_type();
  }

  onnx::ModelProto policy_only = BuildPolicyModel(snapshot_, nullptr, {});
  EXPECT_NO_THROW(CheckModel(policy_only));
  ASSERT_EQ(policy_only.graph().output_size(), 1);
  EXPECT_EQ(policy_only.graph().output(0).name(), "action");
  // 16 x 12 + 16, 8 x 16 + 8, 5 x 8 + 5 weights, and the normaliser's 2 x 12 + 2 numbers.
  int64_t numbers = 0;
  for (const auto& t : policy_only.graph().initializer()) numbers += t.float_data_size();
  EXPECT_EQ(numbers, 208 + 136 + 45 + 26);
}

TEST_P(OnnxExportTest, GraphComputesWhatTheActorsCompute) {
  onnx::ModelProto model = BuildPolicyModel(snapshot_, &value_, metadata_);
  const int rows = 300;
  torch::Tensor raw = Observations(rows);
  // The actors: RunningStats::Normalize (double) on the snapshot's statistics, then the policy.
  RunningStats stats = StatsFromSnapshot(snapshot_);
  std::vector<float> normalized(rows * kObs);
  stats.Normalize(raw.data_ptr<float>(), rows, normalized.data());
  torch::Tensor z = torch::from_blob(normalized.data(), {rows, kObs});
  const double clipped = (z.abs() >= 10.0f).to(torch::kFloat64).mean().item<double>();
  EXPECT_GT(clipped, 0.05) << "the normaliser's clip is not exercised";
  torch::Tensor action, value;
  {
    torch::NoGradGuard no_grad;
    GaussianPolicy policy = PolicyFromSnapshot(snapshot_);
    action = policy->forward(z);
    value = value_.critic->forward(z).unsqueeze(1) * value_.scale + value_.offset;
  }
  EXPECT_GT(action.abs().max().item<float>(), 0.5f);

  torch::NoGradGuard no_grad;
  auto out = RunGraph(model, raw);
  ASSERT_TRUE(out.count("action") && out.count("value"));
  EXPECT_EQ(out["action"].sizes().vec(), action.sizes().vec());
  EXPECT_EQ(out["value"].sizes().vec(), (std::vector<int64_t>{rows, 1}));
  EXPECT_LE((out["observation_normalised"] - z).abs().max().item<float>(), 1e-5f);
  // Within float32 rounding of the same arithmetic: 1e-5 absolute plus 1e-5 of the value, as
  // numpy's allclose. One 2-core machine with AVX-512 gave 1.3e-5 on elu's actions, where others
  // stayed within 1e-5 absolute (libtorch picks its exp kernels by CPU; not traced further).
  auto close = [](const torch::Tensor& got, const torch::Tensor& want) {
    return ((got - want).abs() - 1e-5 * want.abs()).max().item<float>();
  };
  EXPECT_LE(close(out["action"], action), 1e-5f);
  EXPECT_LE(close(out["value"], value), 1e-5f);
}

INSTANTIATE_TEST_SUITE_P(Activations, OnnxExportTest, ::testing::Values("tanh", "relu", "elu"));

class OnnxExportErrorsTest : public OnnxExportTest {
 protected:
  OnnxExportErrorsTest() : folder_(fs::temp_directory_path() / ("onnx-export-test-" + Pid())) {
    fs::create_directories(folder_);
  }
  ~OnnxExportErrorsTest() override { fs::remove_all(folder_); }
  static std::string Pid() { return std::to_string(::getpid()); }
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(folder_))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  fs::path folder_;
};

TEST_P(OnnxExportErrorsTest, RefusesSnapshotsThatDoNotFitOrAreNotFinite) {
  v1::PolicySnapshot wrong_shape = snapshot_;
  float w[3] = {1, 2, 3};
  *wrong_shape.mutable_parameters(0)->mutable_tensor() = wire::FloatTensor(w, {3});
  EXPECT_THROW(BuildPolicyModel(wrong_shape, nullptr, {}), std::invalid_argument);

  v1::PolicySnapshot short_stats = snapshot_;
  *short_stats.mutable_observation_mean() = wire::FloatTensor(w, {3});
  EXPECT_THROW(BuildPolicyModel(short_stats, nullptr, {}), std::invalid_argument);

  {
    torch::NoGradGuard no_grad;
    value_.critic->parameters()[0][0][0] = std::nanf("");
  }
  try {
    BuildPolicyModel(snapshot_, &value_, {});
    ADD_FAILURE() << "a NaN critic weight was exported";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("critic.0.weight holds a non-finite value at index 0"),
              std::string::npos)
        << e.what();
  }
  ValueHead other_size{ValueNetwork(kObs + 1, policy_->config()), 1, 0};
  EXPECT_THROW(BuildPolicyModel(snapshot_, &other_size, {}), std::invalid_argument);
}

TEST_P(OnnxExportErrorsTest, WritesBothFilesWholeOrNeither) {
  const std::string bytes = BuildPolicyModel(snapshot_, nullptr, metadata_).SerializeAsString();
  const std::string onnx_path = (folder_ / "policy.onnx").string();
  const std::string json_path = (folder_ / "policy.json").string();
  WritePolicyFiles(bytes, onnx_path, "{}\n", json_path);
  EXPECT_EQ(Files(), (std::vector<std::string>{"policy.json", "policy.onnx"}));
  std::ifstream in(onnx_path, std::ios::binary);
  const std::string written((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(written, bytes);
  EXPECT_EQ(fs::file_size(json_path), 3u);

  // A graph the checker refuses (a node reading a tensor nothing defines): neither file changes.
  onnx::ModelProto broken = BuildPolicyModel(snapshot_, nullptr, metadata_);
  broken.mutable_graph()->mutable_node(0)->set_input(1, "nowhere");
  try {
    WritePolicyFiles(broken.SerializeAsString(), onnx_path, "[]\n", json_path);
    ADD_FAILURE() << "a graph reading an undefined tensor was written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("policy.onnx: not written: the ONNX checker refuses"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(WritePolicyFiles("not a model", onnx_path, "[]\n", json_path), std::runtime_error);
  EXPECT_EQ(Files(), (std::vector<std::string>{"policy.json", "policy.onnx"}));
  EXPECT_EQ(fs::file_size(json_path), 3u);

  // A folder that does not exist for the sidecar: the model is not written either.
  const std::string elsewhere = (folder_ / "missing" / "policy.json").string();
  try {
    WritePolicyFiles(bytes, (folder_ / "other.onnx").string(), "{}\n", elsewhere);
    ADD_FAILURE() << "wrote into a missing folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(elsewhere + ": cannot write (No such file"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(Files(), (std::vector<std::string>{"policy.json", "policy.onnx"}));
  EXPECT_THROW(WritePolicyFiles(bytes, onnx_path, "{}", onnx_path), std::runtime_error);
}

INSTANTIATE_TEST_SUITE_P(Tanh, OnnxExportErrorsTest, ::testing::Values("tanh"));

}  // namespace
}  // namespace ragdoll::exports
