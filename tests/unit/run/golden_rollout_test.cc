// Rollouts recorded once and compared byte for byte in every later build: the shipped steering
// policy (tests/data/steer_policy) acting in its own environment, and the walk stepped with a
// fixed stream of actions. A refactoring that claims to change no behaviour must leave these
// digests alone; a change that means to alter the simulation, the reward or the observation
// rewrites tests/data/golden_rollouts.txt with RAGDOLL_WRITE_GOLDEN=1 and says why in its commit.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "actor/rollout.h"
#include "run/experiment.h"
#include "run/trained_policy.h"
#include "sim/imitation_env.h"
#include "sim/motion_set.h"

namespace ragdoll {
namespace {

const std::string kGoldenFile = std::string(RAGDOLL_TEST_DATA_DIR) + "/golden_rollouts.txt";

// FNV-1a, 64 bits: exact and order-sensitive, which is all a byte-for-byte comparison needs.
class Digest {
 public:
  void Add(const void* data, size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) hash_ = (hash_ ^ p[i]) * 1099511628211ull;
  }
  void Add(const std::string& bytes) { Add(bytes.data(), bytes.size()); }
  void Add(double x) { Add(&x, sizeof x); }
  std::string Hex() const {
    std::ostringstream out;
    out << std::hex << hash_;
    return out.str();
  }

 private:
  uint64_t hash_ = 14695981039346656037ull;
};

std::map<std::string, std::string> ReadGolden() {
  std::map<std::string, std::string> golden;
  std::ifstream in(kGoldenFile);
  std::string name, digest;
  while (in >> name >> digest) golden[name] = digest;
  return golden;
}

// Compares `digest` with the recorded one, or records it under RAGDOLL_WRITE_GOLDEN=1.
void ExpectGolden(const std::string& name, const std::string& digest) {
  std::map<std::string, std::string> golden = ReadGolden();
  if (std::getenv("RAGDOLL_WRITE_GOLDEN") != nullptr) {
    golden[name] = digest;
    std::ofstream out(kGoldenFile);
    for (const auto& [n, d] : golden) out << n << " " << d << "\n";
    return;
  }
  ASSERT_TRUE(golden.count(name)) << "no digest for '" << name << "' in " << kGoldenFile;
  EXPECT_EQ(golden[name], digest) << name << ": the rollout changed";
}

// An episode figure by name; 0 when the episode has none of that name.
double Figure(const v1::EpisodeSummary& e, const std::string& name) {
  for (const v1::Figure& f : e.figures()) {
    if (f.name() == name) return f.value();
  }
  return 0;
}

// The figures of a finished episode in a fixed order.
void AddEpisode(const v1::EpisodeSummary& e, Digest* digest) {
  for (double x : {e.episode_return(), static_cast<double>(e.length()), e.normalized_return(),
                   Figure(e, "rotation"), Figure(e, "velocity"), Figure(e, "end_effector"),
                   Figure(e, "com"), Figure(e, "root"), e.fell() ? 1.0 : 0.0, Figure(e, "task"),
                   Figure(e, "speed_error"), Figure(e, "heading_error")}) {
    digest->Add(x);
  }
}

TEST(GoldenRolloutTest, SteeringPolicyInItsEnvironment) {
  run::TrainedPolicy trained =
      run::LoadTrainedPolicy(std::string(RAGDOLL_TEST_DATA_DIR) + "/steer_policy");
  actor::RolloutWorker worker(trained.experiment.environment, 4, 64, 2026, "golden");
  worker.SetPolicy(trained.snapshot);
  Digest digest;
  int episodes = 0;
  for (int round = 0; round < 6; ++round) {
    for (const v1::TrajectorySegment& s : worker.Collect()) {
      for (const v1::Tensor* t : {&s.observations(), &s.actions(), &s.log_probs(), &s.rewards(),
                                  &s.terminated(), &s.truncated(), &s.final_observations()}) {
        digest.Add(t->data());
      }
      for (const v1::EpisodeSummary& e : s.episodes()) AddEpisode(e, &digest);
      episodes += s.episodes_size();
    }
  }
  EXPECT_GT(episodes, 0);  // the figures of finished episodes are part of the record
  ExpectGolden("steer_policy_4x64x6", digest.Hex());
}

TEST(GoldenRolloutTest, WalkWithAFixedActionStream) {
  run::Experiment experiment =
      run::ReadExperiment(std::string(RAGDOLL_SOURCE_DIR) + "/configs/walk.yaml");
  const sim::EnvConfig& config = experiment.environment;
  auto character = character::Character::Load(config.character, config.physics_dt());
  sim::ImitationEnv env(character, sim::LoadMotionSet(config, *character), config, 17);
  std::vector<float> obs(env.spec().observation_size), action(env.spec().action_size);
  std::mt19937 rng(3);
  Digest digest;
  env.Reset(obs.data());
  int episodes = 0;
  for (int step = 0; step < 1200; ++step) {
    // Integer draws mapped by hand: the same floats from any standard library.
    for (float& a : action) a = static_cast<float>(rng() % 2001) / 2000.0f - 0.5f;
    sim::StepResult r = env.Step(action.data(), obs.data());
    digest.Add(obs.data(), obs.size() * sizeof(float));
    digest.Add(r.reward);
    digest.Add(r.terminated ? 1.0 : 0.0);
    digest.Add(r.truncated ? 1.0 : 0.0);
    if (r.terminated || r.truncated) {
      const sim::EpisodeStats& e = env.episode();
      for (double x : {e.episode_return, e.normalized_return, static_cast<double>(e.length),
                       e.mean_terms.rotation, e.mean_terms.velocity, e.mean_terms.end_effector,
                       e.mean_terms.com, e.mean_terms.root}) {
        digest.Add(x);
      }
      ++episodes;
      env.Reset(obs.data());
    }
  }
  EXPECT_GT(episodes, 0);
  ExpectGolden("walk_fixed_actions_1200", digest.Hex());
}

}  // namespace
}  // namespace ragdoll
