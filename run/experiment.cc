#include "run/experiment.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "character/character.h"
#include "common/config_section.h"
#include "sim/motion_set.h"

namespace ragdoll::run {

namespace {

// The `actors:` section (after the trainer's, whose time horizon the actors share).
void ReadActors(const ConfigSection& actors, Experiment* e) {
  e->actor_count = actors.Get<int>("count", 0);
  if (e->actor_count < 0) actors.Fail("count", "must be 0 (one per spare core) or more");
  e->actor.environments = actors.Get<int>("environments", e->actor.environments);
  if (e->actor.environments < 1) actors.Fail("environments", "must be at least 1");
  e->actor.threads = actors.Get<int>("threads", e->actor.threads);
  if (e->actor.threads < 1) actors.Fail("threads", "must be at least 1");
  e->actor.seed = actors.Get<uint64_t>("seed", e->actor.seed);
  e->actor.heartbeat_interval = actors.Get<double>("heartbeat_interval", 1.0);
  if (!(e->actor.heartbeat_interval > 0)) actors.Fail("heartbeat_interval", "must be positive");
  actors.Finish();
  e->actor.time_horizon = e->trainer.time_horizon;
}

void ReadBroker(const ConfigSection& section, broker::BrokerConfig* config) {
  config->endpoints = ReadEndpoints(section);
  config->actor_timeout = section.Get<double>("actor_timeout", config->actor_timeout);
  if (!(config->actor_timeout > 0)) section.Fail("actor_timeout", "must be positive");
  section.Finish();
}

// Every port of the run from `port_base` on.
void SetPorts(int port_base, Experiment* e) {
  Endpoints& p = e->broker.endpoints;
  p.trajectory_port = port_base;
  p.control_port = port_base + 1;
  p.snapshot_port = port_base + 2;
  p.learner_port = port_base + 3;
  p.learner_snapshot_port = port_base + 4;
  e->learner.store_port = port_base + 5;
  e->metrics.learner_port = port_base + 10;
  e->metrics.broker_port = port_base + 11;
  e->metrics.actor_port = port_base + 20;
  e->metrics.learner_replica_port = port_base + 50;
}

// The effective configuration: the file with its paths made absolute and the contacts
// resolved, so that it still works from the run folder (evaluation reads it from there).
void WriteEffectiveConfig(const ConfigSection& root, Experiment* e) {
  e->tree = root.Clone();
  if (e->environment.steering.enabled()) {
    YAML::Node items = e->tree["environment"]["steering"]["motions"];
    for (size_t i = 0; i < e->environment.steering.motions.size(); ++i) {
      items[i]["motion"] =
          std::filesystem::absolute(e->environment.steering.motions[i].motion).string();
    }
  } else {
    e->tree["environment"]["motion"] = std::filesystem::absolute(e->environment.motion).string();
  }
  if (e->environment.recovery.enabled()) {
    YAML::Node recovery = e->tree["environment"]["recovery"];
    recovery["face_down"] = std::filesystem::absolute(e->environment.recovery.face_down).string();
    recovery["face_up"] = std::filesystem::absolute(e->environment.recovery.face_up).string();
  }
  e->tree["environment"]["character"] =
      std::filesystem::absolute(e->environment.character).string();
  YAML::Node contacts(YAML::NodeType::Sequence);
  for (const auto& body : e->environment.allowed_contacts) contacts.push_back(body);
  contacts.SetStyle(YAML::EmitterStyle::Flow);
  e->tree["environment"]["allowed_contacts"] = contacts;
  YAML::Emitter out;
  out << e->tree;
  e->text = std::string(out.c_str()) + "\n";
}

}  // namespace

Experiment ReadExperiment(const std::string& path, int port_base) {
  Experiment e;
  e.path = path;
  e.name = std::filesystem::path(path).stem().string();
  ConfigSection root = ConfigSection::FromFile(path);
  e.environment =
      sim::ReadEnvConfig(root.Section("environment"), character::DefaultCharacterPath());
  e.trainer = learner::ReadTrainerConfig(root.Section("trainer"));
  ReadActors(root.Section("actors"), &e);
  ReadBroker(root.Section("broker"), &e.broker);
  e.learner = learner::ReadReplicaSettings(root.Section("learner"));
  e.metrics = ReadMetricsConfig(root.Section("metrics"));
  ConfigSection security = root.Section("security");
  e.keys_dir = security.GetPath("keys", "");
  security.Finish();
  root.Finish();

  if (port_base > 0) SetPorts(port_base, &e);

  // `allowed_contacts: auto` resolved here as the environment will resolve it, so that start-up
  // can print the list and the run's effective configuration records it.
  if (e.environment.contacts_from_clip) {
    auto character =
        character::Character::Load(e.environment.character, e.environment.physics_dt());
    e.environment.allowed_contacts =
        sim::GroundContacts(*sim::LoadMotionSet(e.environment, *character), *character);
  }

  WriteEffectiveConfig(root, &e);
  return e;
}

int ResolveActorCount(int configured) {
  if (configured > 0) return configured;
  int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, cores - 1);
}

}  // namespace ragdoll::run
