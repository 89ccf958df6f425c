#include "learner/learner.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <atomic>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <thread>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <csignal>

#include "common/config_section.h"
#include "learner/checkpoint_file.h"
#include "learner/checkpoint_store.h"
#include "learner/learner_process.h"
#include "learner/ppo.h"
#include "learner/replica_group.h"
#include "learner/trainer_config.h"
#include "tests/unit/error_of.h"

namespace ragdoll::learner {
namespace {

constexpr int kObs = 5, kAct = 2, kT = 8;

TrainerConfig SmallConfig() {
  TrainerConfig c;
  c.batch_size = 16;
  c.buffer_size = 32;
  c.num_epoch = 2;
  c.time_horizon = kT;
  c.network.hidden_units = {8, 8};
  c.max_steps = 1000;
  c.max_policy_lag = 1;
  return c;
}

// A valid segment of random numbers, with one inner truncation and one termination.
v1::TrajectorySegment RandomSegment(std::mt19937& rng, int64_t version, float reward_scale = 1) {
  std::normal_distribution<float> g(0, 1);
  std::vector<float> obs((kT + 1) * kObs), act(kT * kAct), logp(kT), rew(kT), fin(kObs);
  for (float& x : obs) x = g(rng);
  for (float& x : act) x = g(rng);
  for (float& x : logp) x = -2 + 0.1f * g(rng);
  for (float& x : rew) x = reward_scale * g(rng);
  for (float& x : fin) x = g(rng);
  std::vector<uint8_t> term(kT, 0), trunc(kT, 0);
  trunc[3] = 1;
  term[6] = 1;
  v1::TrajectorySegment s;
  s.set_policy_version(version);
  *s.mutable_observations() = wire::FloatTensor(obs.data(), {kT + 1, kObs});
  *s.mutable_actions() = wire::FloatTensor(act.data(), {kT, kAct});
  *s.mutable_log_probs() = wire::FloatTensor(logp.data(), {kT});
  *s.mutable_rewards() = wire::FloatTensor(rew.data(), {kT});
  *s.mutable_terminated() = wire::ByteTensor(term.data(), {kT});
  *s.mutable_truncated() = wire::ByteTensor(trunc.data(), {kT});
  *s.mutable_final_observations() = wire::FloatTensor(fin.data(), {1, kObs});
  auto* e = s.add_episodes();
  e->set_episode_return(3.5);
  e->set_length(7);
  e->set_normalized_return(0.5);
  EXPECT_TRUE(wire::CheckSegment(s, kObs, kAct).ok());
  return s;
}

void Fill(Learner& learner, uint32_t seed, float reward_scale = 1) {
  std::mt19937 rng(seed);
  while (!learner.Ready()) {
    ASSERT_EQ(learner.Add(RandomSegment(rng, learner.version(), reward_scale)),
              Learner::Accept::kAccepted);
  }
}

// One update of each learner on the same segments (`fill`) with the same random draws.
std::pair<UpdateStats, UpdateStats> UpdateAlike(Learner& a, Learner& b, uint32_t fill) {
  Fill(a, fill);
  Fill(b, fill);
  torch::manual_seed(7);
  UpdateStats first = a.Update();
  torch::manual_seed(7);
  return {first, b.Update()};
}

bool SameParameters(torch::nn::Module& a, torch::nn::Module& b) {
  auto pa = a.named_parameters(), pb = b.named_parameters();
  if (pa.size() != pb.size()) return false;
  for (const auto& item : pa) {
    if (!torch::equal(item.value(), pb[item.key()])) return false;
  }
  return true;
}

class LearnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("ragdoll_learner_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

TEST_F(LearnerTest, UpdateBumpsVersionCountsSamplesAndUpdatesStatistics) {
  torch::manual_seed(1);
  Learner learner(SmallConfig(), kObs, kAct);
  Fill(learner, 1);
  EXPECT_EQ(learner.buffered_samples(), 32);
  EXPECT_EQ(learner.episodes().episodes, 4);
  EXPECT_DOUBLE_EQ(learner.episodes().Mean(learner.episodes().episode_return), 3.5);
  UpdateStats u = learner.Update();
  EXPECT_EQ(learner.version(), 1);
  EXPECT_EQ(learner.samples(), 32);
  EXPECT_EQ(learner.iterations(), 1);
  EXPECT_EQ(learner.buffered_samples(), 0);
  EXPECT_EQ(u.samples, 32);
  EXPECT_TRUE(std::isfinite(u.policy_loss) && std::isfinite(u.value_loss));
  EXPECT_GT(u.value_loss, 0);
  EXPECT_NEAR(u.learning_rate, 3e-4, 1e-15);  // linear schedule at 0 samples
  EXPECT_EQ(learner.stats().count(), 32);     // observations of the 32 steps
}

TEST_F(LearnerTest, DropsSegmentsOlderThanMaxPolicyLag) {
  torch::manual_seed(1);
  Learner learner(SmallConfig(), kObs, kAct);
  Fill(learner, 1);
  learner.Update();
  Fill(learner, 2);
  learner.Update();  // version 2; max_policy_lag 1 accepts versions 1 and 2
  std::mt19937 rng(3);
  EXPECT_EQ(learner.Add(RandomSegment(rng, 0)), Learner::Accept::kStale);
  EXPECT_EQ(learner.Add(RandomSegment(rng, 1)), Learner::Accept::kAccepted);
  EXPECT_EQ(learner.stale_dropped(), 1);
}

// Save then load restores parameters, optimiser state and counters: the next update of the
// restored learner is bit-identical to the next update of the original.
TEST_F(LearnerTest, VersionsNeverGoBackwardAfterResumingFromAnOlderCheckpoint) {
  torch::manual_seed(1);
  Learner learner(SmallConfig(), kObs, kAct);
  Fill(learner, 1);
  learner.Update();
  EXPECT_EQ(learner.version(), 1);
  // Resumed at v1 while the actors already run v7 (the learner died between checkpoints): their
  // segments are welcome, and the next version is 8, not 2.
  std::mt19937 rng(2);
  while (!learner.Ready()) {
    ASSERT_EQ(learner.Add(RandomSegment(rng, 7)), Learner::Accept::kAccepted);
  }
  EXPECT_EQ(learner.newest_seen_version(), 7);
  learner.Update();
  EXPECT_EQ(learner.version(), 8);
  // What the broker says runs counts the same way; a lower number changes nothing.
  learner.ContinueNumberingFrom(20);
  EXPECT_EQ(learner.version(), 20);
  learner.ContinueNumberingFrom(3);
  EXPECT_EQ(learner.version(), 20);
  // A version impossibly far ahead is dropped, not followed.
  EXPECT_EQ(learner.Add(RandomSegment(rng, 20 + Learner::kMaxVersionAhead + 1)),
            Learner::Accept::kStale);
  EXPECT_EQ(learner.newest_seen_version(), 7);
}

TEST_F(LearnerTest, CheckpointRestoresTrainingStateExactly) {
  torch::manual_seed(1);
  Learner original(SmallConfig(), kObs, kAct);
  Fill(original, 1);
  original.Update();
  Fill(original, 2);
  original.Update();
  const std::string path = (dir_ / "checkpoint.pt").string();
  original.Save(path, "trainer: {}\n");
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));

  torch::manual_seed(99);  // a different initialisation, overwritten by Load
  Learner restored(SmallConfig(), kObs, kAct);
  EXPECT_EQ(restored.Load(path), "trainer: {}\n");
  EXPECT_EQ(restored.version(), 2);
  EXPECT_EQ(restored.samples(), 64);
  EXPECT_EQ(restored.iterations(), 2);
  EXPECT_TRUE(SameParameters(*original.policy(), *restored.policy()));
  EXPECT_TRUE(SameParameters(*original.critic(), *restored.critic()));
  EXPECT_EQ(original.stats().mean(), restored.stats().mean());
  EXPECT_EQ(original.stats().var(), restored.stats().var());

  UpdateAlike(original, restored, 3);
  // Adam's moments were restored too: otherwise this step would differ.
  EXPECT_TRUE(SameParameters(*original.policy(), *restored.policy()));
  EXPECT_TRUE(SameParameters(*original.critic(), *restored.critic()));
}

// --init-from a run whose observation this one's extends (a task's entries appended): the policy
// and critic compute what the source's did whatever the new entries hold, the statistics of the
// new entries start at mean 0, variance 1; other sizes are refused.
TEST_F(LearnerTest, WeightsLoadIntoALearnerWithMoreObservationEntries) {
  torch::manual_seed(1);
  Learner source(SmallConfig(), kObs, kAct);
  Fill(source, 1);
  source.Update();
  const std::string path = (dir_ / "source.pt").string();
  source.Save(path, "trainer: {}\n");
  EXPECT_EQ(CheckpointSizes(path), std::make_pair(kObs, kAct));

  Learner grown(SmallConfig(), kObs + 2, kAct);
  grown.LoadWeights(path);
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::randn({5, kObs});
  const torch::Tensor extended = torch::cat({x, torch::randn({5, 2})}, 1);
  EXPECT_TRUE(torch::allclose(grown.policy()->forward(extended), source.policy()->forward(x)));
  EXPECT_TRUE(torch::allclose(grown.critic()->forward(extended), source.critic()->forward(x)));
  ASSERT_EQ(grown.stats().mean().size(), static_cast<size_t>(kObs + 2));
  for (int i = 0; i < kObs; ++i) {
    EXPECT_EQ(grown.stats().mean()[i], source.stats().mean()[i]);
    EXPECT_EQ(grown.stats().var()[i], source.stats().var()[i]);
  }
  EXPECT_EQ(grown.stats().mean()[kObs + 1], 0.0);
  EXPECT_EQ(grown.stats().var()[kObs + 1], 1.0);

  // The source's optimizer is not read: a run with the noise fixed starts from one that learned it.
  TrainerConfig fixed_noise = SmallConfig();
  fixed_noise.learn_log_std = false;
  Learner fixed(fixed_noise, kObs + 2, kAct);
  fixed.LoadWeights(path);
  EXPECT_TRUE(torch::equal(fixed.policy()->log_std, source.policy()->log_std));

  Learner smaller(SmallConfig(), kObs - 1, kAct);
  EXPECT_THROW(smaller.LoadWeights(path), ConfigError);
  Learner other_actions(SmallConfig(), kObs + 2, kAct + 1);
  EXPECT_THROW(other_actions.LoadWeights(path), ConfigError);
}

// A shipped checkpoint (`export --run`) leaves out Adam's state: a third the size, the same
// policy, critic and statistics, and training from it starts the optimizer afresh.
TEST_F(LearnerTest, ACheckpointWithoutOptimizerStateKeepsThePolicyAndRestartsAdam) {
  torch::manual_seed(1);
  Learner original(SmallConfig(), kObs, kAct);
  Fill(original, 1);
  original.Update();
  const std::string whole = original.SaveToBytes("trainer: {}\n");
  const std::string slim = original.SaveToBytes("trainer: {}\n", /*with_optimizer=*/false);
  EXPECT_LT(slim.size(), whole.size() * 0.6);

  torch::manual_seed(99);
  Learner restored(SmallConfig(), kObs, kAct);
  EXPECT_EQ(restored.LoadFromBytes(slim, "slim"), "trainer: {}\n");
  EXPECT_FALSE(restored.optimizer_restored());
  EXPECT_EQ(restored.version(), 1);
  EXPECT_TRUE(SameParameters(*original.policy(), *restored.policy()));
  EXPECT_TRUE(SameParameters(*original.critic(), *restored.critic()));
  EXPECT_EQ(original.stats().mean(), restored.stats().mean());
  Learner again(SmallConfig(), kObs, kAct);
  again.LoadFromBytes(whole, "whole");
  EXPECT_TRUE(again.optimizer_restored());

  // Training goes on from it; the step differs from the original's, whose Adam moments it lacks.
  UpdateAlike(original, restored, 2);
  EXPECT_EQ(restored.version(), 2);
  EXPECT_FALSE(SameParameters(*original.policy(), *restored.policy()));
}

// The adaptive schedule moves the rate every minibatch and a checkpoint carries it: a resumed
// run continues with the same rate and takes the same steps.
TEST_F(LearnerTest, AdaptiveScheduleMovesTheRateAndResumesIt) {
  TrainerConfig config = SmallConfig();
  config.schedule = TrainerConfig::Schedule::kAdaptive;
  config.target_kl = 1e-9;  // any step is too large: the rate falls 1.5x per minibatch, except
                            // after the first of an update, which has not moved the policy yet
  torch::manual_seed(1);
  Learner original(config, kObs, kAct);
  Fill(original, 1);
  UpdateStats first = original.Update();
  // 2 epochs x (32 samples / batch 16) = 4 minibatches: x1.5, then /1.5 three times.
  EXPECT_NEAR(first.learning_rate, 3e-4 / std::pow(1.5, 2), 1e-15);
  EXPECT_GT(first.update_kl, 0);
  const std::string path = (dir_ / "adaptive.pt").string();
  original.Save(path, "");
  Learner restored(config, kObs, kAct);
  restored.Load(path);
  const auto [a, b] = UpdateAlike(original, restored, 2);
  EXPECT_NEAR(a.learning_rate, 3e-4 / std::pow(1.5, 4), 1e-15);
  EXPECT_EQ(a.learning_rate, b.learning_rate);
  EXPECT_TRUE(SameParameters(*original.policy(), *restored.policy()));
}

// normalize_value: the critic learns returns scaled by their running mean and std. The statistics
// after one update are those of the update's value targets, computed here from the segments by
// the reference GAE; the value loss is in units of their spread whatever the reward scale.
TEST_F(LearnerTest, ValueNormalisationScalesTheTargetsByTheirStatistics) {
  constexpr float kScale = 1000;
  TrainerConfig config = SmallConfig();
  config.normalize_value = true;
  torch::manual_seed(1);
  Learner learner(config, kObs, kAct);
  // The value targets as the learner computes them: the critic's output (statistics at mean 0,
  // variance 1 before the first update) on observations normalised by fresh statistics.
  std::mt19937 rng(1);
  const int64_t n = config.buffer_size / kT;
  torch::Tensor obs = torch::empty({n, kT + 1, kObs}), rewards = torch::empty({n, kT});
  torch::Tensor term = torch::zeros({n, kT}), trunc = torch::zeros({n, kT});
  torch::Tensor finals = torch::empty({n, kObs});
  for (int64_t i = 0; i < n; ++i) {
    v1::TrajectorySegment s = RandomSegment(rng, 0, kScale);
    std::memcpy(obs[i].data_ptr<float>(), s.observations().data().data(), (kT + 1) * kObs * 4);
    std::memcpy(rewards[i].data_ptr<float>(), s.rewards().data().data(), kT * 4);
    std::memcpy(finals[i].data_ptr<float>(), s.final_observations().data().data(), kObs * 4);
    term[i][6] = 1;
    trunc[i][3] = 1;
  }
  torch::Tensor values, next_values;
  {
    torch::NoGradGuard no_grad;
    const double unit = std::sqrt(1 + 1e-8);
    auto value = [&](const torch::Tensor& o) {
      return learner.critic()->forward((o / unit).clamp(-10, 10)) * unit;
    };
    torch::Tensor all = value(obs.reshape({-1, kObs})).reshape({n, kT + 1});
    values = all.slice(1, 0, kT).contiguous();
    next_values = all.slice(1, 1, kT + 1).clone();
    next_values.select(1, 3).copy_(value(finals));
  }
  torch::Tensor returns =
      ComputeGae(rewards, values, next_values, term, trunc, config.gamma, config.lambd).returns;
  const double mean = returns.mean().item<double>();
  const double var = returns.to(torch::kFloat64).var(/*unbiased=*/false).item<double>();
  ASSERT_GT(var, 1e4);  // the scale is what the normalisation must take out

  Fill(learner, 1, kScale);
  UpdateStats u = learner.Update();
  EXPECT_EQ(learner.return_stats().count(), 32);
  EXPECT_NEAR(learner.return_stats().mean()[0], mean, 1e-4 * std::sqrt(var));
  EXPECT_NEAR(learner.return_stats().var()[0], var, 1e-4 * var);
  EXPECT_LT(u.value_loss, 5);  // ~0.5 for unit-variance targets and a critic near 0

  // Without it, the same data gives a loss in the targets' own (squared) units.
  torch::manual_seed(1);
  Learner plain(SmallConfig(), kObs, kAct);
  Fill(plain, 1, kScale);
  EXPECT_GT(plain.Update().value_loss, 0.1 * var);
  EXPECT_EQ(plain.return_stats().count(), 0);

  // A checkpoint carries the statistics.
  const std::string path = (dir_ / "value_norm.pt").string();
  learner.Save(path, "");
  Learner restored(config, kObs, kAct);
  restored.Load(path);
  EXPECT_EQ(restored.return_stats().mean(), learner.return_stats().mean());
  EXPECT_EQ(restored.return_stats().var(), learner.return_stats().var());
  EXPECT_EQ(restored.return_stats().count(), 32);
}

// network_settings.learn_log_std: false keeps the action noise where init_log_std put it, even
// with an entropy bonus pulling on it; true lets the update move it.
TEST_F(LearnerTest, FixedActionNoiseStaysAtItsInitialValue) {
  for (bool learn : {false, true}) {
    TrainerConfig config = SmallConfig();
    config.learn_log_std = learn;
    config.beta = 0.1;
    config.network.init_log_std = -1.5;
    torch::manual_seed(1);
    Learner learner(config, kObs, kAct);
    Fill(learner, 1);
    UpdateStats u = learner.Update();
    EXPECT_TRUE(std::isfinite(u.policy_loss));
    torch::Tensor moved = (learner.policy()->log_std + 1.5).abs().max();
    if (learn) {
      EXPECT_GT(moved.item<float>(), 1e-5);
    } else {
      EXPECT_EQ(moved.item<float>(), 0.0f);
      EXPECT_NEAR(u.entropy, kAct * (0.5 + 0.5 * std::log(2 * M_PI) - 1.5), 1e-5);
    }
  }
}

TEST_F(LearnerTest, BadCheckpointsAreRejectedNamingTheFile) {
  Learner learner(SmallConfig(), kObs, kAct);
  const std::string garbage = (dir_ / "garbage.pt").string();
  std::ofstream(garbage) << "not a checkpoint";
  try {
    learner.Load(garbage);
    FAIL() << "expected an error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(garbage), std::string::npos) << e.what();
  }
  // A checkpoint of other sizes.
  Learner other(SmallConfig(), kObs + 1, kAct);
  const std::string wrong = (dir_ / "wrong.pt").string();
  other.Save(wrong, "");
  try {
    learner.Load(wrong);
    FAIL() << "expected an error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sizes 6/2"), std::string::npos) << e.what();
  }
  // Truncated file: an error, never a crash; the learner keeps its state.
  const std::string good = (dir_ / "good.pt").string();
  learner.Save(good, "");
  auto size = std::filesystem::file_size(good);
  std::filesystem::resize_file(good, size / 2);
  EXPECT_THROW(learner.Load(good), ConfigError);
}

TEST_F(LearnerTest, CheckpointFilesCarryAChecksumThatCatchesTruncationAndBitFlips) {
  Learner learner(SmallConfig(), kObs, kAct);
  const std::string path = (dir_ / "checkpoint-000000000032.pt").string();
  learner.Save(path, "trainer: {}\n");
  std::ifstream in(path, std::ios::binary);
  std::string header;
  std::getline(in, header);
  const std::string payload = learner.SaveToBytes("trainer: {}\n");
  EXPECT_EQ(header, "ragdoll-checkpoint 1 bytes=" + std::to_string(payload.size()) +
                        " sha256=" + Sha256Hex(payload));
  bool verified = false;
  EXPECT_EQ(ReadCheckpointFile(path, &verified).size(), payload.size());
  EXPECT_TRUE(verified);
  // SHA-256 of "abc" (FIPS 180-2's test vector).
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");

  auto damaged = [&](const std::string& name, auto change) {
    const std::string copy = (dir_ / name).string();
    std::filesystem::copy_file(path, copy, std::filesystem::copy_options::overwrite_existing);
    std::fstream f(copy, std::ios::in | std::ios::out | std::ios::binary);
    change(f, copy);
    f.close();
    return copy;
  };
  const auto size = std::filesystem::file_size(path);
  const std::string truncated = damaged("truncated.pt", [&](std::fstream&, const std::string& c) {
    std::filesystem::resize_file(c, size - 100);
  });
  EXPECT_EQ(CheckCheckpointFile(truncated),
            truncated + ": truncated: " + std::to_string(payload.size() - 100) +
                " bytes of training state, the header says " + std::to_string(payload.size()));
  // One bit flipped in the middle of the training state.
  const std::string flipped = damaged("flipped.pt", [&](std::fstream& f, const std::string&) {
    f.seekg(static_cast<std::streamoff>(size / 2));
    char c = 0;
    f.get(c);
    f.seekp(static_cast<std::streamoff>(size / 2));
    f.put(static_cast<char>(c ^ 0x10));
  });
  EXPECT_NE(CheckCheckpointFile(flipped).find("checksum mismatch"), std::string::npos);
  const std::string header_hit = damaged("header.pt", [&](std::fstream& f, const std::string&) {
    f.seekp(30);
    f.put('#');
  });
  EXPECT_NE(CheckCheckpointFile(header_hit).find("damaged header"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { learner.Load(flipped); }).find(flipped + ": checksum mismatch"),
            std::string::npos);
  const std::string empty = (dir_ / "empty.pt").string();
  std::ofstream(empty).close();
  EXPECT_EQ(CheckCheckpointFile(empty), empty + ": empty file: not a checkpoint");

  // A checkpoint written before checksums (a bare libtorch archive) still loads, unverified.
  const std::string old = (dir_ / "old.pt").string();
  std::ofstream(old, std::ios::binary) << payload;
  EXPECT_EQ(ReadCheckpointFile(old, &verified), payload);
  EXPECT_FALSE(verified);
  Learner restored(SmallConfig(), kObs, kAct);
  EXPECT_EQ(restored.Load(old), "trainer: {}\n");
}

TEST_F(LearnerTest, TheNewestWholeCheckpointIsFoundAndTheDamagedOnesNamed) {
  Learner learner(SmallConfig(), kObs, kAct);
  const auto folder = dir_ / "run" / "checkpoints";
  std::filesystem::create_directories(folder);
  for (int samples : {100, 200, 300}) {
    char name[64];
    std::snprintf(name, sizeof(name), "checkpoint-%012d.pt", samples);
    learner.Save((folder / name).string(), "");
  }
  const std::string run = (dir_ / "run").string();
  std::vector<std::string> skipped;
  EXPECT_EQ(FindGoodCheckpoint(run, &skipped), (folder / "checkpoint-000000000300.pt").string());
  EXPECT_TRUE(skipped.empty());
  const auto newest = folder / "checkpoint-000000000300.pt";
  std::filesystem::resize_file(newest, std::filesystem::file_size(newest) / 2);
  std::ofstream(folder / "checkpoint-000000000200.pt", std::ios::app) << "x";  // one byte more
  EXPECT_EQ(FindGoodCheckpoint(run, &skipped), (folder / "checkpoint-000000000100.pt").string());
  ASSERT_EQ(skipped.size(), 2u);
  EXPECT_NE(skipped[0].find("checkpoint-000000000300.pt: truncated"), std::string::npos);
  EXPECT_NE(skipped[1].find("checkpoint-000000000200.pt: has extra bytes"), std::string::npos);
  // A damaged file asked for by name is an error, not a silent substitute.
  EXPECT_NE(ErrorOf([&] { FindGoodCheckpoint(newest.string()); }).find("truncated"),
            std::string::npos);
  std::filesystem::resize_file(folder / "checkpoint-000000000100.pt", 10);
  skipped.clear();
  EXPECT_EQ(FindGoodCheckpoint(run, &skipped), "");
  EXPECT_EQ(skipped.size(), 3u);
}

TEST_F(LearnerTest, ACheckpointThatDoesNotFitFailsCleanlyAndKeepsTheOldOne) {
  Learner learner(SmallConfig(), kObs, kAct);
  const std::string path = (dir_ / "checkpoint.pt").string();
  learner.Save(path, "first");
  const auto before = std::filesystem::file_size(path);
  // A file size limit below one checkpoint: the write fails with EFBIG (SIGXFSZ ignored, as the
  // learner process does), like a full disk.
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit saved{};
  getrlimit(RLIMIT_FSIZE, &saved);
  rlimit small = saved;
  small.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  const std::string error = ErrorOf([&] { learner.Save(path, "second"); });
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, SIG_DFL);
  EXPECT_NE(error.find("cannot write the checkpoint (File too large)"), std::string::npos) << error;
  EXPECT_NE(error.find("previous checkpoints are untouched"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  EXPECT_EQ(std::filesystem::file_size(path), before);
  Learner restored(SmallConfig(), kObs, kAct);
  EXPECT_EQ(restored.Load(path), "first");
}

TEST_F(LearnerTest, SnapshotCarriesPolicyAndStatistics) {
  torch::manual_seed(1);
  Learner learner(SmallConfig(), kObs, kAct);
  Fill(learner, 1);
  learner.Update();
  v1::PolicySnapshot s = learner.Snapshot();
  EXPECT_TRUE(wire::CheckSnapshot(s).ok());
  EXPECT_EQ(s.version(), 1);
  EXPECT_EQ(s.network().hidden_units_size(), 2);
  GaussianPolicy copy = PolicyFromSnapshot(s);
  torch::Tensor x = torch::randn({3, kObs});
  EXPECT_TRUE(torch::equal(copy->forward(x), learner.policy()->forward(x)));
  RunningStats stats = StatsFromSnapshot(s);
  for (int i = 0; i < kObs; ++i) {
    EXPECT_NEAR(stats.mean()[i], learner.stats().mean()[i], 1e-6);
  }
}

// Two replicas (threads of this process, over Gloo on loopback) that each see half of the
// segments take exactly the same steps, and the same steps as one learner given the union: with
// one minibatch per epoch the gradient is the union's mean whatever the order, and advantages,
// observation and return statistics are the union's.
ReplicaGroupConfig TestGroup(int rank, int port) {
  ReplicaGroupConfig g;
  g.rank = rank;
  g.size = 2;
  g.store_port = port;
  g.timeout = std::chrono::seconds(20);
  return g;
}

// A port the system reports free right now (bound to port 0, then released). A fixed range or an
// offset from one can collide with concurrent tests and their connections.
int FreePort() {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    throw std::runtime_error("no free port");
  }
  ::close(fd);
  return ntohs(address.sin_port);
}

// Two replicas' final states (`finals`) against one learner (`single`) that trained on the union
// of their data from the same `initial` state.
void ExpectReplicasSteppedAsOneLearner(const TrainerConfig& c,
                                       const std::vector<std::string>& finals, Learner& single,
                                       const std::string& initial, int64_t updates) {
  Learner a(c, kObs, kAct), b(c, kObs, kAct), start(c, kObs, kAct);
  a.LoadFromBytes(finals[0], "replica 0");
  b.LoadFromBytes(finals[1], "replica 1");
  start.LoadFromBytes(initial, "initial");
  EXPECT_TRUE(SameParameters(*a.policy(), *b.policy()));
  EXPECT_TRUE(SameParameters(*a.critic(), *b.critic()));
  EXPECT_EQ(a.samples(), single.samples());
  EXPECT_EQ(a.version(), updates);
  EXPECT_DOUBLE_EQ(a.stats().count(), single.stats().count());
  for (int j = 0; j < kObs; ++j) {
    EXPECT_NEAR(a.stats().mean()[j], single.stats().mean()[j], 1e-9);
    EXPECT_NEAR(a.stats().var()[j], single.stats().var()[j], 1e-9);
  }
  EXPECT_NEAR(a.return_stats().mean()[0], single.return_stats().mean()[0], 1e-6);
  EXPECT_NEAR(a.return_stats().var()[0], single.return_stats().var()[0], 1e-6);
  // Float rounding differs (summation order, float64 advantage moments), and Adam can turn a
  // rounding-sized gradient into a full step, so compare the whole weight vector: its distance
  // from one learner's must be tiny against how far training moved it.
  auto flat = [](Learner& l) {
    std::vector<torch::Tensor> all;
    for (const auto& p : l.policy()->parameters()) all.push_back(p.detach().reshape({-1}));
    for (const auto& p : l.critic()->parameters()) all.push_back(p.detach().reshape({-1}));
    return torch::cat(all);
  };
  const double moved = (flat(single) - flat(start)).norm().item<double>();
  const double differs = (flat(a) - flat(single)).norm().item<double>();
  EXPECT_GT(moved, 1e-3);
  EXPECT_LT(differs, 1e-3 * moved) << "moved " << moved << ", differs " << differs;
}

TEST(LearnerReplicas, TwoReplicasStayIdenticalAndMatchOneLearnerOnTheUnion) {
  TrainerConfig c = SmallConfig();
  c.batch_size = c.buffer_size;  // one minibatch per epoch
  c.num_epoch = 3;
  c.normalize_value = true;
  c.max_policy_lag = 100;
  Learner single(c, kObs, kAct);
  const std::string initial = single.SaveToBytes("");
  const int port = FreePort();
  constexpr int kUpdates = 3;

  std::vector<std::vector<v1::TrajectorySegment>> data(kUpdates);
  std::mt19937 rng(7);
  for (auto& update : data) {
    for (int i = 0; i < c.buffer_size / kT; ++i) update.push_back(RandomSegment(rng, 0));
  }
  std::vector<std::string> finals(2);
  std::vector<double> normalized_returns(2);
  std::vector<std::string> errors(2);
  auto replica = [&](int rank) {
    try {
      ReplicaGroup group(TestGroup(rank, port));
      Learner learner(c, kObs, kAct, &group);
      if (rank == 0) learner.LoadFromBytes(initial, "initial");
      learner.SyncFromRankZero();  // rank 1 starts from other random weights until here
      for (const auto& update : data) {
        for (size_t i = rank; i < update.size(); i += 2) learner.Add(update[i]);
        EXPECT_TRUE(learner.Ready());
        EXPECT_TRUE(learner.AgreeToUpdate(false));
        learner.Update();
        normalized_returns[rank] = learner.episodes().Mean(learner.episodes().normalized_return);
        EXPECT_EQ(learner.episodes().episodes, static_cast<int64_t>(update.size()));
        learner.ResetEpisodeStats();
      }
      finals[rank] = learner.SaveToBytes("");
    } catch (const std::exception& e) {
      errors[rank] = e.what();
    }
  };
  std::thread zero(replica, 0), one(replica, 1);
  zero.join();
  one.join();
  ASSERT_EQ(errors[0], "");
  ASSERT_EQ(errors[1], "");
  for (const auto& update : data) {
    for (const auto& s : update) single.Add(s);
    ASSERT_TRUE(single.Ready());
    single.Update();
  }

  ExpectReplicasSteppedAsOneLearner(c, finals, single, initial, kUpdates);
  EXPECT_DOUBLE_EQ(normalized_returns[0], 0.5);
  EXPECT_DOUBLE_EQ(normalized_returns[1], 0.5);
}

// A replica that was dealt more than its share (it joined first and took the queued backlog)
// takes segments while the other fills its share, and the group then steps as one learner on the
// union: the larger share weighs more.
TEST(LearnerReplicas, AReplicaTakesSegmentsWhileWaitingAndTheUnequalSharesWeighByTheirSize) {
  TrainerConfig c = SmallConfig();
  c.batch_size = c.buffer_size;  // one minibatch per epoch: each replica's whole buffer
  c.num_epoch = 3;
  c.normalize_value = true;
  c.max_policy_lag = 100;
  const int share = c.buffer_size / kT / 2;  // segments
  TrainerConfig union_config = c;            // one learner taking what the two held
  union_config.buffer_size = union_config.batch_size = (2 * share + 1) * kT;
  Learner single(union_config, kObs, kAct);
  const std::string initial = single.SaveToBytes("");
  const int port = FreePort();
  constexpr int kUpdates = 2;
  std::mt19937 rng(11);
  std::vector<std::vector<v1::TrajectorySegment>> data(kUpdates);  // replica 0's, then 1's
  for (auto& update : data) {
    for (int i = 0; i < 2 * share + 1; ++i) update.push_back(RandomSegment(rng, 0));
  }
  std::vector<std::string> finals(2), errors(2);
  std::vector<int64_t> taken_while_waiting(2, 0);
  std::atomic<int> extra_taken{0};
  auto replica = [&](int rank) {
    try {
      ReplicaGroup group(TestGroup(rank, port));
      Learner learner(c, kObs, kAct, &group);
      if (rank == 0) learner.LoadFromBytes(initial, "initial");
      learner.SyncFromRankZero();
      for (int u = 0; u < kUpdates; ++u) {
        const auto& update = data[u];
        const int first = rank == 0 ? 0 : share + 1;
        for (int i = first; i < first + share; ++i) learner.Add(update[i]);
        EXPECT_TRUE(learner.Ready());
        EXPECT_FALSE(learner.Full());
        if (rank == 1) {
          // Joins only once replica 0 has taken its extra segment while waiting.
          while (extra_taken.load() <= u) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        auto meanwhile = [&] {
          ++taken_while_waiting[rank];
          if (rank == 0 && extra_taken.load() == u) {
            learner.Add(update[share]);
            extra_taken.store(u + 1);
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        };
        EXPECT_TRUE(learner.AgreeToUpdate(false, meanwhile));
        UpdateStats stats = learner.Update();
        EXPECT_EQ(stats.samples, (2 * share + 1) * kT);
      }
      finals[rank] = learner.SaveToBytes("");
    } catch (const std::exception& e) {
      errors[rank] = e.what();
    }
  };
  std::thread zero(replica, 0), one(replica, 1);
  zero.join();
  one.join();
  ASSERT_EQ(errors[0], "");
  ASSERT_EQ(errors[1], "");
  EXPECT_GE(taken_while_waiting[0], kUpdates);
  for (const auto& update : data) {
    for (const auto& s : update) single.Add(s);
    ASSERT_TRUE(single.Ready());
    single.Update();
  }
  ExpectReplicasSteppedAsOneLearner(c, finals, single, initial, kUpdates);
}

TEST(LearnerReplicas, OneStoppingReplicaStopsThemAll) {
  const int port = FreePort();
  std::vector<int> agreed(2, -1);
  auto replica = [&](int rank) {
    ReplicaGroup group(TestGroup(rank, port));
    Learner learner(SmallConfig(), kObs, kAct, &group);
    agreed[rank] = learner.AgreeToUpdate(rank == 1) ? 1 : 0;
  };
  std::thread zero(replica, 0), one(replica, 1);
  zero.join();
  one.join();
  EXPECT_EQ(agreed[0], 0);
  EXPECT_EQ(agreed[1], 0);
}

TEST(LearnerReplicas, AReplicaThatLeavesBreaksTheGroupAtOnce) {
  const int port = FreePort();
  std::string error;
  auto zero = std::thread([&] {
    ReplicaGroup group(TestGroup(0, port));
    torch::Tensor t = torch::ones({4});
    group.Sum(t);  // both joined
    try {
      group.Sum(t);  // replica 1 is gone by now
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
  });
  {
    ReplicaGroup group(TestGroup(1, port));
    torch::Tensor t = torch::ones({4});
    group.Sum(t);
    EXPECT_TRUE(torch::equal(t, torch::full({4}, 2.0f)));
  }  // leaves: its connections close
  zero.join();
  EXPECT_THAT(error, ::testing::HasSubstr("a replica stopped or cannot be reached"));
  // Broken by the closed connection ("... by peer"), not by waiting out the timeout.
  EXPECT_THAT(error, ::testing::HasSubstr("by peer"));
}

// FNV-1a, 64 bits: a digest of exact bytes.
class Fnv1a {
 public:
  void Add(const void* data, size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) hash_ = (hash_ ^ bytes[i]) * 1099511628211ULL;
  }
  template <typename T>
  void Add(const T& value) {
    Add(&value, sizeof(value));
  }
  void Add(const torch::Tensor& t) {
    const torch::Tensor c = t.detach().contiguous();
    Add(c.data_ptr(), static_cast<size_t>(c.numel() * c.element_size()));
  }
  void Add(const std::vector<double>& v) { Add(v.data(), v.size() * sizeof(double)); }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 14695981039346656037ULL;
};

// Every number an update leaves behind: the networks, Adam's moments, the statistics and the
// counters, and each update's reported figures (all but its wall time).
void AddState(Fnv1a& digest, Learner& learner) {
  for (const auto& p : learner.policy()->named_parameters()) digest.Add(p.value());
  for (const auto& p : learner.critic()->named_parameters()) digest.Add(p.value());
  auto& optimizer = learner.optimizer();
  for (const auto& p : optimizer.param_groups()[0].params()) {
    const auto& state = static_cast<const torch::optim::AdamParamState&>(
        *optimizer.state().at(c10::guts::to_string(p.unsafeGetTensorImpl())));
    digest.Add(state.step());
    digest.Add(state.exp_avg());
    digest.Add(state.exp_avg_sq());
  }
  digest.Add(learner.stats().mean());
  digest.Add(learner.stats().var());
  digest.Add(learner.stats().count());
  digest.Add(learner.return_stats().mean());
  digest.Add(learner.return_stats().var());
  digest.Add(learner.return_stats().count());
  digest.Add(learner.version());
  digest.Add(learner.samples());
  digest.Add(learner.iterations());
}

void AddStats(Fnv1a& digest, const UpdateStats& u) {
  for (double x : {u.policy_loss, u.value_loss, u.entropy, u.approx_kl, u.update_kl,
                   u.clip_fraction, u.explained_variance, u.learning_rate}) {
    digest.Add(x);
  }
  digest.Add(u.samples);
  digest.Add(u.skipped_steps);
}

// configs/walk.yaml's trainer section with small sizes: 6 segments a buffer, minibatches of 20
// (two a epoch, 8 samples left over), linear schedule, value normalisation, no value clipping.
constexpr const char* kWalkTrainer = R"(
hyperparameters:
  batch_size: 20
  buffer_size: 48
  learning_rate: 3.0e-4
  learning_rate_schedule: linear
  beta: 5.0e-4
  epsilon: 0.2
  lambd: 0.95
  num_epoch: 4
  clip_value_loss: false
network_settings:
  normalize: true
  normalize_value: true
  hidden_units: 16
  num_layers: 2
reward_signals:
  extrinsic:
    gamma: 0.95
max_steps: 1000
time_horizon: 8
max_policy_lag: 2
)";

// The same with the adaptive schedule, value clipping and fixed action noise.
constexpr const char* kAdaptiveTrainer = R"(
hyperparameters:
  batch_size: 16
  buffer_size: 32
  learning_rate_schedule: adaptive
  target_kl: 0.002
  num_epoch: 3
network_settings:
  normalize_value: true
  learn_log_std: false
  hidden_units: 16
  num_layers: 2
max_steps: 1000
time_horizon: 8
)";

// The digest of a learner (in `group`, when given) after three updates from seed 1 on segments
// drawn from seed 5, single-threaded so the sums are always taken in the same order.
uint64_t GoldenDigest(const char* trainer_yaml, ReplicaGroup* group = nullptr) {
  const int threads = at::get_num_threads();
  at::set_num_threads(1);
  TrainerConfig config = ReadTrainerConfig(ConfigSection::FromString(trainer_yaml, "golden"));
  torch::manual_seed(1);
  Learner learner(config, kObs, kAct, group);
  Fnv1a digest;
  std::mt19937 rng(5);
  for (int update = 0; update < 3; ++update) {
    while (!learner.Ready()) learner.Add(RandomSegment(rng, learner.version()));
    EXPECT_TRUE(learner.AgreeToUpdate(false));
    AddStats(digest, learner.Update());
  }
  AddState(digest, learner);
  at::set_num_threads(threads);
  return digest.value();
}

// The learner's numbers, pinned: any change of the update's arithmetic (order of operations,
// random draws, schedules) changes these digests. Recorded anew when Adam's step became one pass
// (learner/adam_step.h, which rounds apart from libtorch's); a deliberate change of the numerics
// records them anew.
TEST(LearnerGolden, AWalkTrainerTakesTheRecordedSteps) {
  EXPECT_EQ(GoldenDigest(kWalkTrainer), 0x0e29c39e38f2d47bULL);
}

TEST(LearnerGolden, AnAdaptiveTrainerTakesTheRecordedSteps) {
  EXPECT_EQ(GoldenDigest(kAdaptiveTrainer), 0x8bb22dea3a880a33ULL);
}

// A group of one replica takes the group's arithmetic (moments over the group, the gradient
// buffer and its KL slot), which differs from a lone learner's in rounding.
TEST(LearnerGolden, AGroupOfOneReplicaTakesTheRecordedSteps) {
  ReplicaGroupConfig g;
  g.store_port = FreePort();
  g.timeout = std::chrono::seconds(20);
  ReplicaGroup group(g);
  EXPECT_EQ(GoldenDigest(kWalkTrainer, &group), 0x4643993c8b2737abULL);
}

TEST(TrainerConfig, ReadsValueNormalisationAndFixedNoise) {
  TrainerConfig defaults = ReadTrainerConfig(ConfigSection::FromString("{}", "t.yaml"));
  EXPECT_FALSE(defaults.normalize_value);
  EXPECT_TRUE(defaults.learn_log_std);
  TrainerConfig c = ReadTrainerConfig(ConfigSection::FromString(
      "network_settings: {normalize_value: true, learn_log_std: false, init_log_std: -2}",
      "t.yaml"));
  EXPECT_TRUE(c.normalize_value);
  EXPECT_FALSE(c.learn_log_std);
  EXPECT_EQ(c.network.init_log_std, -2);
  EXPECT_THROW(ReadTrainerConfig(ConfigSection::FromString(
                   "network_settings: {normalize_value: maybe}", "t.yaml")),
               ConfigError);
}

// The message ReadTrainerConfig refuses `yaml` with (as file t.yaml).
std::string TrainerConfigError(const std::string& yaml) {
  return ErrorOf([&] { ReadTrainerConfig(ConfigSection::FromString(yaml, "t.yaml")); });
}

// Found by fuzz_config: `max_steps: 4e36` was cast to int64 (undefined behaviour).
TEST(TrainerConfig, CountsBeyondTheirTypeAreRefusedNamingTheKey) {
  auto error = TrainerConfigError;
  EXPECT_THAT(error("max_steps: 4e36"),
              ::testing::HasSubstr("max_steps: must be at most 1000000000000000"));
  EXPECT_THAT(error("time_horizon: 1e10"),
              ::testing::HasSubstr("time_horizon: must be at most 2147483647"));
  EXPECT_THAT(error("hyperparameters: {num_epoch: 3e9}"),
              ::testing::HasSubstr("num_epoch: must be at most"));
  EXPECT_EQ(ReadTrainerConfig(ConfigSection::FromString("max_steps: 3.0e7", "t.yaml")).max_steps,
            30000000);
}

// Found by fuzz_config (its slowest inputs): `num_layers: 1e8` built a list of 1e8 layer widths
// before anything could refuse the network.
TEST(TrainerConfig, NetworkSizesHaveACeilingNamingTheKey) {
  auto error = TrainerConfigError;
  EXPECT_THAT(error("network_settings: {num_layers: 1e8}"),
              ::testing::HasSubstr("t.yaml:1: network_settings.num_layers: must be at most 64"));
  EXPECT_THAT(error("network_settings: {hidden_units: 100000}"),
              ::testing::HasSubstr("network_settings.hidden_units: must be at most 8192"));
  TrainerConfig c = ReadTrainerConfig(ConfigSection::FromString(
      "network_settings: {num_layers: 64, hidden_units: 8192}", "t.yaml"));
  EXPECT_EQ(c.network.hidden_units, std::vector<int>(64, 8192));
}

TEST(TrainerConfig, ReadsTheLearningRateSchedule) {
  auto read = [](const std::string& yaml) {
    return ReadTrainerConfig(ConfigSection::FromString(yaml, "t.yaml"));
  };
  EXPECT_EQ(read("{}").schedule, TrainerConfig::Schedule::kLinear);
  TrainerConfig c = read("hyperparameters: {learning_rate_schedule: adaptive, target_kl: 0.02}");
  EXPECT_EQ(c.schedule, TrainerConfig::Schedule::kAdaptive);
  EXPECT_EQ(c.target_kl, 0.02);
  EXPECT_EQ(read("hyperparameters: {learning_rate_schedule: constant}").schedule,
            TrainerConfig::Schedule::kConstant);
  try {
    read("hyperparameters:\n  learning_rate_schedule: kl\n");
    ADD_FAILURE() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(),
                ::testing::HasSubstr("t.yaml:2: hyperparameters.learning_rate_schedule: expected "
                                     "'linear', 'constant' or 'adaptive', got 'kl'"));
  }
}

}  // namespace
}  // namespace ragdoll::learner
