#include "exports/onnx_export.h"

#include <onnx/checker.h>
#include <onnx/defs/schema.h>
#include <onnx/shape_inference/implementation.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace ragdoll::exports {

const char* const kObservationInput = "observation";
const char* const kActionOutput = "action";
const char* const kValueOutput = "value";

namespace {

// RunningStats::Normalize's defaults, which the actors use: a unit test runs the graph against
// that function.
constexpr double kObservationClip = 10.0;
constexpr double kVarianceEpsilon = 1e-8;

void RequireFinite(const float* data, size_t n, const std::string& what) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(data[i])) {
      throw std::invalid_argument(what + " holds a non-finite value at index " + std::to_string(i));
    }
  }
}

void AddInitializer(onnx::GraphProto* graph, const std::string& name,
                    const std::vector<int64_t>& dims, const float* data, size_t n) {
  RequireFinite(data, n, name);
  onnx::TensorProto* t = graph->add_initializer();
  t->set_name(name);
  t->set_data_type(onnx::TensorProto::FLOAT);
  for (int64_t d : dims) t->add_dims(d);
  // float_data rather than raw_data: no byte order to get wrong.
  t->mutable_float_data()->Add(data, data + n);
}

void AddInitializer(onnx::GraphProto* graph, const std::string& name, const torch::Tensor& tensor) {
  torch::Tensor t = tensor.detach().contiguous().to(torch::kFloat32);
  AddInitializer(graph, name, std::vector<int64_t>(t.sizes().begin(), t.sizes().end()),
                 t.data_ptr<float>(), static_cast<size_t>(t.numel()));
}

onnx::NodeProto* AddNode(onnx::GraphProto* graph, const std::string& op,
                         const std::vector<std::string>& inputs, const std::string& output) {
  onnx::NodeProto* node = graph->add_node();
  node->set_op_type(op);
  node->set_name(output);
  for (const auto& input : inputs) node->add_input(input);
  node->add_output(output);
  return node;
}

void SetFloatTensorType(onnx::ValueInfoProto* info, const std::string& name, int64_t width) {
  info->set_name(name);
  auto* tensor = info->mutable_type()->mutable_tensor_type();
  tensor->set_elem_type(onnx::TensorProto::FLOAT);
  auto* shape = tensor->mutable_shape();
  shape->add_dim()->set_dim_param("batch");
  shape->add_dim()->set_dim_value(width);
}

// Appends `net` (Linear layers and activations, as MakeMlp builds them) reading `input`; its
// tensors are named `prefix`.N.weight and so on; the last node writes `output`.
void AddMlp(onnx::GraphProto* graph, torch::nn::Sequential net, const std::string& input,
            const std::string& prefix, const std::string& output) {
  std::string x = input;
  const size_t layers = net->size();
  for (size_t i = 0; i < layers; ++i) {
    const std::string name = prefix + "." + std::to_string(i);
    const std::string y = i + 1 == layers ? output : name + ".out";
    std::shared_ptr<torch::nn::Module> module = net->ptr(i);
    if (auto* linear = module->as<torch::nn::Linear>()) {
      // Gemm with transB: y = x W^T + b, W stored as libtorch keeps it, [out, in].
      AddInitializer(graph, name + ".weight", linear->weight);
      AddInitializer(graph, name + ".bias", linear->bias);
      onnx::NodeProto* gemm = AddNode(graph, "Gemm", {x, name + ".weight", name + ".bias"}, y);
      onnx::AttributeProto* trans_b = gemm->add_attribute();
      trans_b->set_name("transB");
      trans_b->set_type(onnx::AttributeProto::INT);
      trans_b->set_i(1);
    } else if (module->as<torch::nn::Tanh>()) {
      AddNode(graph, "Tanh", {x}, y);
    } else if (module->as<torch::nn::ReLU>()) {
      AddNode(graph, "Relu", {x}, y);
    } else if (auto* elu = module->as<torch::nn::ELU>()) {
      onnx::AttributeProto* alpha = AddNode(graph, "Elu", {x}, y)->add_attribute();
      alpha->set_name("alpha");
      alpha->set_type(onnx::AttributeProto::FLOAT);
      alpha->set_f(static_cast<float>(elu->options.alpha()));
    } else {
      throw std::invalid_argument(prefix + ": layer " + std::to_string(i) + " (" + module->name() +
                                  ") has no ONNX counterpart here");
    }
    x = y;
  }
}

}  // namespace

onnx::ModelProto BuildPolicyModel(const v1::PolicySnapshot& snapshot, const ValueHead* value,
                                  const std::map<std::string, std::string>& metadata) {
  const int64_t O = snapshot.network().observation_size();
  const int64_t A = snapshot.network().action_size();
  // Shapes, finiteness and non-negative variances, then every parameter's name and shape against
  // the architecture.
  wire::Verdict verdict = wire::CheckSnapshot(snapshot);
  if (!verdict.ok()) throw std::invalid_argument("policy snapshot: " + verdict.detail);
  GaussianPolicy policy = PolicyFromSnapshot(snapshot);
  const std::vector<float> mean = wire::FloatValues(snapshot.observation_mean());
  const std::vector<float> var = wire::FloatValues(snapshot.observation_var());
  // The actors widen the snapshot's float statistics to double and multiply by
  // 1 / sqrt(var + epsilon) in double; the graph multiplies by that factor rounded to float.
  std::vector<float> inv_std(O);
  for (int64_t j = 0; j < O; ++j) {
    inv_std[j] =
        static_cast<float>(1.0 / std::sqrt(static_cast<double>(var[j]) + kVarianceEpsilon));
  }

  onnx::ModelProto model;
  model.set_ir_version(kOnnxIrVersion);
  model.set_producer_name("ragdoll");
  model.set_producer_version(RAGDOLL_VERSION);
  model.set_model_version(snapshot.version());
  model.set_doc_string(
      "Deterministic ragdoll policy (mean action) with observation normalisation folded in: feed "
      "the raw observation, get the action. The JSON sidecar describes both.");
  onnx::OperatorSetIdProto* opset = model.add_opset_import();
  opset->set_domain("");
  opset->set_version(kOnnxOpset);
  for (const auto& [key, text] : metadata) {
    onnx::StringStringEntryProto* entry = model.add_metadata_props();
    entry->set_key(key);
    entry->set_value(text);
  }

  onnx::GraphProto* graph = model.mutable_graph();
  graph->set_name("ragdoll_policy");
  SetFloatTensorType(graph->add_input(), kObservationInput, O);
  AddInitializer(graph, "observation_mean", {O}, mean.data(), mean.size());
  AddInitializer(graph, "observation_inv_std", {O}, inv_std.data(), inv_std.size());
  const float low = static_cast<float>(-kObservationClip),
              high = static_cast<float>(kObservationClip);
  AddInitializer(graph, "observation_clip_min", {}, &low, 1);
  AddInitializer(graph, "observation_clip_max", {}, &high, 1);
  AddNode(graph, "Sub", {kObservationInput, "observation_mean"}, "observation_centred");
  AddNode(graph, "Mul", {"observation_centred", "observation_inv_std"}, "observation_scaled");
  AddNode(graph, "Clip", {"observation_scaled", "observation_clip_min", "observation_clip_max"},
          "observation_normalised");

  AddMlp(graph, policy->mean, "observation_normalised", "policy", kActionOutput);
  SetFloatTensorType(graph->add_output(), kActionOutput, A);

  if (value != nullptr) {
    if (value->critic.is_empty()) throw std::invalid_argument("value head without a critic");
    if (!std::isfinite(value->scale) || !std::isfinite(value->offset)) {
      throw std::invalid_argument("value scale or offset is not finite");
    }
    torch::nn::Sequential critic = value->critic->net;
    auto* first = critic->ptr(0)->as<torch::nn::Linear>();
    if (first == nullptr || first->weight.size(1) != O) {
      throw std::invalid_argument("the critic does not take the policy's " + std::to_string(O) +
                                  " observations");
    }
    const bool scaled = value->scale != 1.0 || value->offset != 0.0;
    AddMlp(graph, critic, "observation_normalised", "critic",
           scaled ? "critic_output" : kValueOutput);
    if (scaled) {
      const float scale = static_cast<float>(value->scale);
      const float offset = static_cast<float>(value->offset);
      AddInitializer(graph, "value_scale", {}, &scale, 1);
      AddInitializer(graph, "value_offset", {}, &offset, 1);
      AddNode(graph, "Mul", {"critic_output", "value_scale"}, "value_scaled");
      AddNode(graph, "Add", {"value_scaled", "value_offset"}, kValueOutput);
    }
    SetFloatTensorType(graph->add_output(), kValueOutput, 1);
  }
  return model;
}

void CheckModel(const onnx::ModelProto& model) {
  try {
    onnx::checker::check_model(model);
    onnx::ModelProto inferred = model;
    onnx::shape_inference::InferShapes(inferred, onnx::OpSchemaRegistry::Instance(),
                                       onnx::ShapeInferenceOptions(/*check_type=*/true,
                                                                   /*strict_mode=*/1));
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("the ONNX checker refuses the model: ") + e.what());
  }
}

namespace {

// Writes `bytes` to a new temporary file beside `path` and returns its name.
std::string WriteTemporary(const std::string& path, const std::string& bytes) {
  const std::string temporary = path + ".tmp";
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  if (!out) {
    throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
  }
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    throw std::runtime_error(path + ": cannot write (" + reason + ")");
  }
  return temporary;
}

}  // namespace

void WritePolicyFiles(const std::string& model_bytes, const std::string& onnx_path,
                      const std::string& sidecar_text, const std::string& sidecar_path) {
  if (onnx_path == sidecar_path) {
    throw std::runtime_error(onnx_path + ": the model and its sidecar need different files");
  }
  onnx::ModelProto model;
  if (!model.ParseFromString(model_bytes)) {
    throw std::runtime_error(onnx_path + ": the model's bytes do not parse as an ONNX model");
  }
  try {
    CheckModel(model);
  } catch (const std::exception& e) {
    throw std::runtime_error(onnx_path + ": not written: " + e.what());
  }
  const std::string model_temporary = WriteTemporary(onnx_path, model_bytes);
  std::string sidecar_temporary;
  try {
    sidecar_temporary = WriteTemporary(sidecar_path, sidecar_text);
  } catch (...) {
    std::remove(model_temporary.c_str());
    throw;
  }
  // Both files are whole before either is renamed (each within its own folder). Should the
  // second rename fail, the new model goes too: a model never sits beside a sidecar that is not
  // its own.
  std::error_code error;
  std::filesystem::rename(model_temporary, onnx_path, error);
  bool model_placed = !error;
  if (model_placed) std::filesystem::rename(sidecar_temporary, sidecar_path, error);
  if (error) {
    std::remove(model_temporary.c_str());
    std::remove(sidecar_temporary.c_str());
    if (model_placed) std::remove(onnx_path.c_str());
    throw std::runtime_error((model_placed ? sidecar_path : onnx_path) +
                             ": cannot move the written file into place (" + error.message() + ")");
  }
}

}  // namespace ragdoll::exports
