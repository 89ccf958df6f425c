#include "exports/sidecar.h"

#include <mujoco/mujoco.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "character/character.h"
#include "character/motion_clip.h"
#include "common/whole_file.h"
#include "exports/onnx_export.h"
#include "learner/checkpoint_file.h"
#include "sim/env_config.h"
#include "sim/falls.h"
#include "sim/motion_set.h"

namespace ragdoll::exports {
namespace {
namespace fs = std::filesystem;
// Keys in the order written: the sidecar reads top-down, model first.
using json = nlohmann::ordered_json;

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
json ActionAxes(const character::Character& character) {
  const mjModel* m = character.model();
  json axes = json::array();
  for (size_t i = 0; i < character.hinges().size(); ++i) {
    const character::ActuatedHinge& h = character.hinges()[i];
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
json ReferenceAngles(const character::Character& character, const character::MotionClip& clip,
                     double dt) {
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
                     {"sha256", learner::Sha256Hex(ReadWholeFile(file))},
                     {"duration", e.clip->duration()},
                     {"loop", false},
                     {"hinge_angles", ReferenceAngles(env.character(), *e.clip, c.control_dt())}});
  }
  const character::MotionClip& base = *set.entry(set.commands().front()).clip;
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

// The model's outputs: the mean action, and with `value` the critic's estimate of the return.
json ModelOutputs(const run::TrainedPolicy& p, const sim::EnvSpec& spec, bool value) {
  json outputs = json::array();
  outputs.push_back({{"name", kActionOutput},
                     {"shape", {"batch", spec.action_size}},
                     {"dtype", "float32"},
                     {"meaning",
                      "the policy's mean action, one per action axis in action.axes order; not "
                      "clipped: clip to [-1, 1] as action.to_pd_target says"}});
  if (value) {
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
  return outputs;
}

// The model file: its name beside the sidecar, its checksum, the ONNX versions and its tensors.
json ModelSection(const run::TrainedPolicy& p, const sim::EnvSpec& spec,
                  const SidecarModel& model) {
  return {
      {"file", fs::path(model.onnx_path).filename().string()},
      {"sha256", learner::Sha256Hex(model.bytes)},
      {"bytes", model.bytes.size()},
      {"opset", kOnnxOpset},
      {"ir_version", kOnnxIrVersion},
      {"inputs",
       json::array({{{"name", kObservationInput},
                     {"shape", {"batch", spec.observation_size}},
                     {"dtype", "float32"},
                     {"meaning",
                      "the raw observation (observation.names order); the model normalises it"}}})},
      {"outputs", ModelOutputs(p, spec, model.value)}};
}

// Which checkpoint the model was made from, and the network's shape.
json PolicySection(const run::TrainedPolicy& p) {
  return {{"checkpoint", p.checkpoint},
          {"version", p.version},
          {"samples", p.samples},
          {"deterministic", true},
          {"hidden_units", std::vector<int>(p.snapshot.network().hidden_units().begin(),
                                            p.snapshot.network().hidden_units().end())},
          {"activation", p.snapshot.network().activation()}};
}

// The character file the policy drives, and the frame every quantity is given in.
json CharacterSection(const character::Character& character) {
  return {{"file", character.path()},
          {"sha256", learner::Sha256Hex(ReadWholeFile(character.path()))},
          {"mass", character.total_mass()},
          {"frame", "Z up, +X forward, +Y left; metres, radians, seconds"}};
}

// The clip the policy imitates.
json ClipSection(const sim::EnvConfig& c, const sim::ImitationEnv& env) {
  return {{"name", env.clip().name()},
          {"file", c.motion},
          {"sha256", learner::Sha256Hex(ReadWholeFile(c.motion))},
          {"duration", env.clip().duration()},
          {"loop", env.clip().loop()}};
}

// How often the policy acts and how the physics steps between its actions.
json ControlSection(const sim::EnvConfig& c, const character::Character& character) {
  return {{"frequency", c.control_frequency},
          {"dt", c.control_dt()},
          {"substeps", c.substeps},
          {"physics_timestep", c.physics_dt()},
          {"integrator", IntegratorName(character.model()->opt.integrator)},
          {"max_episode_steps", c.max_episode_steps}};
}

// What the model takes: the observation's entries and how they are built.
json ObservationSection(const sim::EnvSpec& spec) {
  return {{"size", spec.observation_size},
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
           "values"}};
}

// What the model gives: how an action becomes each hinge's PD target and how that is driven.
json ActionSection(const sim::EnvConfig& c, const sim::EnvSpec& spec,
                   const character::Character& character) {
  const bool offset = c.action_mode == sim::ActionMode::kOffset;
  return {{"size", spec.action_size},
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
          {"axes", ActionAxes(character)}};
}

// The clip's hinge angles, which offset-mode actions are added to.
json ReferenceSection(const sim::EnvConfig& c, const sim::ImitationEnv& env) {
  return {{"time_step", c.control_dt()},
          {"meaning",
           "the clip's hinge angles (radians, action.axes order) at clip times 0, dt, 2 dt, ... "
           "through one pass; episodes in training start in the clip's pose and velocities at a "
           "random phase"},
          {"hinge_angles", ReferenceAngles(env.character(), env.clip(), c.control_dt())}};
}

// When a training episode ends.
json EpisodeSection(const sim::EnvConfig& c, const sim::ImitationEnv& env) {
  return {{"allowed_contacts", env.allowed_contacts()},
          {"max_root_distance", c.max_root_distance},
          {"ends_when",
           "a body not in allowed_contacts touches the ground, or the root is further than "
           "max_root_distance from the reference root"}};
}

}  // namespace

json PolicySidecar(const run::TrainedPolicy& policy, const sim::ImitationEnv& env,
                   const SidecarModel& model) {
  const sim::EnvConfig& c = policy.experiment.environment;
  const sim::EnvSpec& spec = env.spec();
  return {
      {"format", "ragdoll-policy"},
      {"format_version", 1},
      {"ragdoll_version", RAGDOLL_VERSION},
      {"model", ModelSection(policy, spec, model)},
      {"policy", PolicySection(policy)},
      {"character", CharacterSection(env.character())},
      {"clip", ClipSection(c, env)},
      {"steering", c.steering.enabled() ? Steering(c, env) : json(nullptr)},
      {"recovery", c.recovery.enabled() ? Recovery(c, env) : json(nullptr)},
      {"control", ControlSection(c, env.character())},
      {"observation", ObservationSection(spec)},
      {"action", ActionSection(c, spec, env.character())},
      {"reference", ReferenceSection(c, env)},
      {"episode", EpisodeSection(c, env)},
  };
}

}  // namespace ragdoll::exports
