#include "cli/export_command.h"

#include <mujoco/mujoco.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "actor/rollout.h"
#include "actor/sim/falls.h"
#include "cli/onnx_export.h"
#include "cli/trained_policy.h"
#include "common/config_section.h"
#include "learner/checkpoint_file.h"
#include "learner/learner.h"

namespace ragdoll::cli {
namespace {
namespace fs = std::filesystem;
// Keys in the order written: the sidecar reads top-down, model first.
using json = nlohmann::ordered_json;

struct ExportOptions {
  std::string target, onnx, sidecar, run;
  bool value = false;
};

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot read");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

const char* IntegratorName(int integrator) {
  switch (integrator) {
    case mjINT_EULER:
      return "Euler (semi-implicit, joint damping implicit)";
    case mjINT_RK4:
      return "RK4";
    default:
      return "implicit";
  }
}

// Each action axis: which hinge it drives, its range and its PD drive as the character model
// has them.
json ActionAxes(const sim::Character& character) {
  const mjModel* m = character.model();
  json axes = json::array();
  for (size_t i = 0; i < character.hinges().size(); ++i) {
    const sim::ActuatedHinge& h = character.hinges()[i];
    const int joint = m->dof_jntid[h.dof_address];
    const int body = m->jnt_bodyid[joint];
    const int a = h.actuator;
    json axis = {
        {"index", i},
        {"name", h.name},
        {"joint", character.joints()[h.joint].name},
        // A joint's hinges compose as intrinsic rotations in this order (0 first).
        {"order_in_joint", h.qpos_address - character.joints()[h.joint].qpos_address},
        {"body", mj_id2name(m, mjOBJ_BODY, body)},
        {"axis", {m->jnt_axis[3 * joint], m->jnt_axis[3 * joint + 1], m->jnt_axis[3 * joint + 2]}},
        {"lower", h.lower},
        {"upper", h.upper},
        {"kp", m->actuator_gainprm[a * mjNGAIN]},
        {"kd", m->dof_damping[h.dof_address]},
        {"armature", m->dof_armature[h.dof_address]},
    };
    if (m->actuator_forcelimited[a]) {
      axis["force_limit"] = {m->actuator_forcerange[2 * a], m->actuator_forcerange[2 * a + 1]};
    }
    axes.push_back(axis);
  }
  return axes;
}

// The reference pose's hinge angles at clip times 0, dt, 2 dt, ... through one pass of the clip:
// the centre of each offset-mode action, and the pose to start an episode in.
json ReferenceAngles(const sim::Character& character, const sim::MotionClip& clip, double dt) {
  std::vector<double> qpos(character.model()->nq);
  const int steps = static_cast<int>(std::ceil(clip.duration() / dt - 1e-9));
  json rows = json::array();
  for (int i = 0; i <= steps; ++i) {
    character.PoseToQpos(clip.Sample(i * dt), qpos.data());
    json row = json::array();
    for (const auto& h : character.hinges()) row.push_back(qpos[h.qpos_address]);
    rows.push_back(row);
  }
  return rows;
}

// The steering task's contract: the commands, the clips that demonstrate them, the transitions,
// and how the command part of the observation is built.
json Steering(const sim::EnvConfig& c, const sim::ImitationEnv& env) {
  const sim::MotionSet& set = env.motion_set();
  json clips = json::array();
  for (const sim::MotionSetEntry& e : set.entries()) {
    if (e.get_up) continue;  // in "recovery"
    json clip = {{"name", e.name},
                 {"duration", e.clip->duration()},
                 {"loop", e.clip->loop()},
                 {"hinge_angles", ReferenceAngles(env.character(), *e.clip, c.control_dt())}};
    if (e.transition()) {
      clip["transition"] = {{"from", set.entry(e.from).name}, {"to", set.entry(e.to).name}};
    } else {
      clip["command"] = {{"forward", e.command.forward},
                         {"left", e.command.left},
                         {"turn_deg_per_s", e.command.turn * 180 / M_PI}};
    }
    clips.push_back(clip);
  }
  return {{"clips", clips},
          {"command_inputs",
           "observation entries after phase.cos: command.forward, command.left = the commanded "
           "velocity (m/s, the clip's command) turned into the character's heading frame, i.e. by "
           "(desired_heading - heading); command.turn = the command's turn rate (rad/s); "
           "command.heading_error.sin, .cos of (desired_heading - heading); then reference.<clip> "
           "for every clip in clips order: 1 for the clip whose hinge_angles the actions offset "
           "now, else 0. desired_heading starts at the character's heading and advances by "
           "turn * dt every control step."},
          {"switching",
           "on a new command the reference becomes its clip (or the transition clip from the old "
           "command's clip, when one is listed, which hands over to its `to` clip when it ends), "
           "entered at the key frame whose joint rotations are closest to the character's; the "
           "phase entries then follow that clip. With catch_steps: told to stand (the command "
           "nearest zero), when the pelvis's horizontal speed exceeds `above` m/s while the stand "
           "clip is the reference, the reference becomes for `seconds` the command clip whose "
           "command is nearest the pelvis velocity seen from the desired heading (none if that is "
           "the stand), entered as above; the command entries stay the stand's, and a command "
           "given meanwhile waits until the step ends and the reference leads to it (through a "
           "listed transition from the stepping clip)"},
          {"catch_steps", c.steering.catch_above > 0 ? json{{"above", c.steering.catch_above},
                                                            {"seconds", c.steering.catch_seconds}}
                                                     : json(nullptr)},
          {"task_reward",
           {{"velocity_weight", c.steering.velocity_weight},
            {"heading_weight", c.steering.heading_weight},
            {"velocity_scale", c.steering.velocity_scale},
            {"heading_scale", c.steering.heading_scale},
            {"velocity_window", c.steering.velocity_window}}}};
}

// Falling and getting up: the get-up clips, how a fall is seen, how the reference switches and
// hands back, and the observation entries that say which get-up plays.
json Recovery(const sim::EnvConfig& c, const sim::ImitationEnv& env) {
  const sim::MotionSet& set = env.motion_set();
  json clips = json::array();
  for (const sim::MotionSetEntry& e : set.entries()) {
    if (!e.get_up) continue;
    const std::string& file =
        e.name == "get_up_face_down" ? c.recovery.face_down : c.recovery.face_up;
    clips.push_back({{"name", e.name},
                     {"file", file},
                     {"sha256", learner::Sha256Hex(ReadFile(file))},
                     {"duration", e.clip->duration()},
                     {"loop", false},
                     {"hinge_angles", ReferenceAngles(env.character(), *e.clip, c.control_dt())}});
  }
  const sim::MotionClip& base = *set.entry(set.commands().front()).clip;
  return {
      {"clips", clips},
      {"may_touch_floor", sim::GroundContacts(set, env.character())},
      {"stand_height", sim::StandHeight(base)},
      {"inputs",
       "the last two observation entries, recovery.face_down and recovery.face_up: 1 for the "
       "get-up clip whose hinge_angles the actions offset now, else 0 (both 0 while not getting "
       "up)"},
      {"switching",
       "a fall is a contact between the floor and a body not in may_touch_floor; the reference "
       "then becomes get_up_face_down when the pelvis's forward (+X) axis points below the "
       "horizontal, else get_up_face_up, entered at the key frame (of its first 90 %) whose joint "
       "rotations are closest to the character's and turned about the vertical so that the yaw "
       "of the pelvis's forward plus up axes matches the character's. When the clip has played: "
       "if the character stands (pelvis up axis within 30 degrees of vertical, pelvis above "
       "stand_height) the reference returns to the clip it left at its closest key frame (with "
       "steering: to the stand for stand_after_get_up seconds, the command entries the stand's, "
       "then to the current command through the transition listed from the stand, if any); if "
       "not, the get-up starts again the same way."},
      {"stand_after_get_up", c.recovery.stand_after_get_up}};
}

json Sidecar(const TrainedPolicy& p, sim::ImitationEnv& env, const ExportOptions& o,
             const std::string& model_bytes) {
  const sim::EnvConfig& c = p.experiment.environment;
  const sim::EnvSpec& spec = env.spec();
  const sim::Character& character = env.character();
  const bool offset = c.action_mode == sim::ActionMode::kOffset;
  json outputs = json::array();
  outputs.push_back({{"name", kActionOutput},
                     {"shape", {"batch", spec.action_size}},
                     {"dtype", "float32"},
                     {"meaning",
                      "the policy's mean action, one per action axis in action.axes order; not "
                      "clipped: clip to [-1, 1] as action.to_pd_target says"}});
  if (o.value) {
    outputs.push_back(
        {{"name", kValueOutput},
         {"shape", {"batch", 1}},
         {"dtype", "float32"},
         {"meaning",
          "the critic's estimate of the discounted return (gamma below) still to come from this "
          "observation under the training policy, in reward units: each control step earns at "
          "most max_reward_per_step; value normalisation, if any, is already undone"},
         {"gamma", p.experiment.trainer.gamma},
         {"max_reward_per_step", spec.max_reward_per_step}});
  }
  json s = {
      {"format", "ragdoll-policy"},
      {"format_version", 1},
      {"ragdoll_version", RAGDOLL_VERSION},
      {"model",
       {{"file", fs::path(o.onnx).filename().string()},
        {"sha256", learner::Sha256Hex(model_bytes)},
        {"bytes", model_bytes.size()},
        {"opset", kOnnxOpset},
        {"ir_version", kOnnxIrVersion},
        {"inputs",
         json::array(
             {{{"name", kObservationInput},
               {"shape", {"batch", spec.observation_size}},
               {"dtype", "float32"},
               {"meaning",
                "the raw observation (observation.names order); the model normalises it"}}})},
        {"outputs", outputs}}},
      {"policy",
       {{"checkpoint", p.checkpoint},
        {"version", p.version},
        {"samples", p.samples},
        {"deterministic", true},
        {"hidden_units", std::vector<int>(p.snapshot.network().hidden_units().begin(),
                                          p.snapshot.network().hidden_units().end())},
        {"activation", p.snapshot.network().activation()}}},
      {"character",
       {{"file", character.path()},
        {"sha256", learner::Sha256Hex(ReadFile(character.path()))},
        {"mass", character.total_mass()},
        {"frame", "Z up, +X forward, +Y left; metres, radians, seconds"}}},
      {"clip",
       {{"name", env.clip().name()},
        {"file", c.motion},
        {"sha256", learner::Sha256Hex(ReadFile(c.motion))},
        {"duration", env.clip().duration()},
        {"loop", env.clip().loop()}}},
      {"steering", c.steering.enabled() ? Steering(c, env) : json(nullptr)},
      {"recovery", c.recovery.enabled() ? Recovery(c, env) : json(nullptr)},
      {"control",
       {{"frequency", c.control_frequency},
        {"dt", c.control_dt()},
        {"substeps", c.substeps},
        {"physics_timestep", c.physics_dt()},
        {"integrator", IntegratorName(character.model()->opt.integrator)},
        {"max_episode_steps", c.max_episode_steps}}},
      {"observation",
       {{"size", spec.observation_size},
        {"names", spec.observation_names},
        {"layout",
         "root.height: world z of the root body (m). Every other entry is in the heading frame: "
         "world axes turned about +Z by minus the root's yaw, so the root faces +X. "
         "root.rot.*: first two columns of the root's rotation matrix in that frame "
         "(xx, yx, zx, xy, yy, zy); root.vel, root.angvel: linear velocity of the root's centre "
         "of mass and angular velocity. Then per body, in this order: pos = body origin minus "
         "root origin, rot.* as for the root, vel = its centre of mass's linear velocity, "
         "angvel. phase: clip time / duration in [0, 1] (wrapping for a looping clip), then "
         "sin and cos of 2 pi phase."},
        {"normalisation",
         "inside the model: (x - mean) / sqrt(var + 1e-8), clipped to [-10, 10]; feed raw "
         "values"}}},
      {"action",
       {{"size", spec.action_size},
        {"mode", offset ? "offset" : "absolute"},
        {"offset_scale", c.offset_scale},
        {"to_pd_target",
         offset ? "a = clamp(action, -1, 1) (a non-finite action counts as 0); target = "
                  "reference.hinge_angles at clip time t + dt + a * offset_scale * (upper - "
                  "lower) / 2, clamped to [lower, upper]; t is the clip time at the start of "
                  "the control step"
                : "a = clamp(action, -1, 1) (a non-finite action counts as 0); target = lower + "
                  "(a + 1) / 2 * (upper - lower)"},
        {"drive",
         "the target is held for the whole control step (substeps physics steps): torque = "
         "clamp(kp * (target - angle), force_limit) from a position actuator, plus joint "
         "damping -kd * angular velocity (passive) and armature as the character file has them"},
        {"axes", ActionAxes(character)}}},
      {"reference",
       {{"time_step", c.control_dt()},
        {"meaning",
         "the clip's hinge angles (radians, action.axes order) at clip times 0, dt, 2 dt, ... "
         "through one pass; episodes in training start in the clip's pose and velocities at a "
         "random phase"},
        {"hinge_angles", ReferenceAngles(character, env.clip(), c.control_dt())}}},
      {"episode",
       {{"allowed_contacts", env.allowed_contacts()},
        {"max_root_distance", c.max_root_distance},
        {"ends_when",
         "a body not in allowed_contacts touches the ground, or the root is further than "
         "max_root_distance from the reference root"}}},
  };
  return s;
}

// Every scalar of `node` that is an absolute path to an existing file.
void CollectFilePaths(const YAML::Node& node, std::set<std::string>* out) {
  if (node.IsScalar()) {
    const std::string v = node.Scalar();
    std::error_code error;
    if (!v.empty() && v[0] == '/' && fs::is_regular_file(v, error)) out->insert(v);
  } else if (node.IsSequence()) {
    for (const auto& item : node) CollectFilePaths(item, out);
  } else if (node.IsMap()) {
    for (const auto& kv : node) CollectFilePaths(kv.second, out);
  }
}

// `export --run OUT`: the run as a folder to ship or check in. Its config.yaml names the files it
// uses (clips, character) relative to OUT, so the folder keeps working wherever it is moved with
// them; its one checkpoint holds the policy and critic without the optimizer's state.
int ExportRun(const ExportOptions& o, const TrainedPolicy& p) {
  const fs::path out = fs::absolute(o.run).lexically_normal();
  const fs::path run_dir = fs::path(p.checkpoint).parent_path().parent_path();
  std::string config = ReadFile((run_dir / "config.yaml").string());
  std::set<std::string> paths;
  try {
    CollectFilePaths(YAML::Load(config), &paths);
  } catch (const YAML::Exception& e) {
    throw ConfigError((run_dir / "config.yaml").string() + ": " + e.what());
  }
  // Longest first, so that no path is rewritten inside a longer one.
  std::vector<std::string> ordered(paths.begin(), paths.end());
  std::sort(ordered.begin(), ordered.end(),
            [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
  for (const auto& path : ordered) {
    const std::string relative = fs::path(path).lexically_relative(out).string();
    for (size_t at = config.find(path); at != std::string::npos;
         at = config.find(path, at + relative.size())) {
      config.replace(at, path.size(), relative);
    }
  }
  const sim::EnvSpec spec = sim::MakeEnvSpec(p.experiment.environment);
  learner::Learner l(p.experiment.trainer, spec.observation_size, spec.action_size);
  l.Load(p.checkpoint);
  const std::string bytes = l.SaveToBytes(config, /*with_optimizer=*/false);
  fs::create_directories(out / "checkpoints");
  const fs::path checkpoint = out / "checkpoints" / fs::path(p.checkpoint).filename();
  learner::WriteCheckpointFile(checkpoint.string(), bytes);
  std::ofstream file(out / "config.yaml");
  file << config;
  if (!file.flush()) throw ConfigError((out / "config.yaml").string() + ": cannot write");
  std::fprintf(stderr,
               "ragdoll export: %s (policy v%lld, %lld samples) -> %s: config.yaml (%zu file "
               "paths made relative to it) and %s (%zu bytes, no optimizer state)\n",
               p.checkpoint.c_str(), static_cast<long long>(p.version),
               static_cast<long long>(p.samples), out.c_str(), paths.size(),
               checkpoint.lexically_relative(out).c_str(), bytes.size());
  return 0;
}

int Export(const ExportOptions& o) {
  if (!fs::exists(o.target)) {
    throw ConfigError(o.target + ": no such run folder or checkpoint file");
  }
  if (o.onnx.empty() && o.run.empty()) throw ConfigError("give --onnx FILE, --run FOLDER or both");
  TrainedPolicy p = LoadTrainedPolicy(o.target);
  if (!o.run.empty()) ExportRun(o, p);
  if (o.onnx.empty()) return 0;
  actor::RolloutWorker probe(p.experiment.environment, 1, 1, 0, "probe");
  sim::ImitationEnv& env = probe.environment(0);
  const std::string sidecar =
      o.sidecar.empty() ? fs::path(o.onnx).replace_extension(".json").string() : o.sidecar;

  ValueHead value{ValueNetwork(p.critic), p.value_scale, p.value_offset};
  const sim::EnvConfig& c = p.experiment.environment;
  std::map<std::string, std::string> metadata = {
      {"ragdoll_version", RAGDOLL_VERSION},
      {"policy_version", std::to_string(p.version)},
      {"policy_samples", std::to_string(p.samples)},
      {"checkpoint", p.checkpoint},
      {"clip", env.clip().name()},
      {"character", env.character().path()},
      {"action_mode", c.action_mode == sim::ActionMode::kOffset ? "offset" : "absolute"},
      {"control_frequency", std::to_string(c.control_frequency)},
      {"sidecar", fs::path(sidecar).filename().string()},
  };
  onnx::ModelProto model = BuildPolicyModel(p.snapshot, o.value ? &value : nullptr, metadata);
  const std::string bytes = model.SerializeAsString();
  const std::string text = Sidecar(p, env, o, bytes).dump(2) + "\n";
  WritePolicyFiles(bytes, o.onnx, text, sidecar);
  std::fprintf(stderr,
               "ragdoll export: %s (policy v%lld, %lld samples) -> %s (%zu bytes, opset %lld: "
               "observation [batch, %d] -> action [batch, %d]%s) and %s\n",
               p.checkpoint.c_str(), static_cast<long long>(p.version),
               static_cast<long long>(p.samples), o.onnx.c_str(), bytes.size(),
               static_cast<long long>(kOnnxOpset), probe.spec().observation_size,
               probe.spec().action_size, o.value ? ", value [batch, 1]" : "", sidecar.c_str());
  return 0;
}

}  // namespace

std::function<int()> AddExportCommand(CLI::App& app) {
  auto o = std::make_shared<ExportOptions>();
  auto* cmd = app.add_subcommand(
      "export",
      "write the trained policy as an ONNX model for game engines, with a JSON sidecar, or as a "
      "run folder to ship");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint file")->required();
  cmd->add_option("--onnx", o->onnx, "the model file to write, e.g. policy.onnx");
  cmd->add_option("--run", o->run,
                  "also (or instead) write the run as a folder to ship: config.yaml with its "
                  "file paths relative to it, and the newest checkpoint without optimizer state "
                  "(eval, render and play take it like the run)");
  cmd->add_flag("--value", o->value, "also output the critic's value [batch, 1]");
  cmd->add_option("--sidecar", o->sidecar, "the JSON sidecar (default: the model's name, .json)");
  return [cmd, o]() -> int {
    if (!*cmd) return -1;
    try {
      return Export(*o);
    } catch (const std::exception& error) {
      std::fprintf(stderr, "ragdoll export: %s\n", error.what());
      return 1;
    }
  };
}

}  // namespace ragdoll::cli
