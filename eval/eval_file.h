// eval.json: what `ragdoll eval` writes (to --json FILE, and into a run folder) and `ragdoll
// report` reads. The writer, the sections it is made of and the reader live here together, so
// that they cannot drift apart; each protocol's section is the JSON object its result makes
// (ToJson). Pure: no MuJoCo, no libtorch.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ragdoll::eval {

// The file's name in a run folder.
inline constexpr char kEvaluationFile[] = "eval.json";

// One deterministic episode's figures, for a clip judged whole from its first frame.
struct EpisodeFigures {
  double normalized_return = 0, episode_length = 0;
  bool fell = false;
};

// What one `ragdoll eval` found, section by section; an empty section is left out of the file.
struct EvaluationSections {
  std::string episodes;       // EvaluationResult::ToJson: the means, with "perturbation" if pushed
  std::string push_protocol;  // PushProtocolResult::ToJson (eval --pushes)
  std::string recovery;       // RecoveryResult::ToJson (eval --recovery)
  std::string commands;       // CommandEvalResult::ToJson (eval --commands), beside its script
  std::string command_script;
  // A clip that plays once: the policy's episode from the first frame, and the reference's PD
  // targets alone over the same episode.
  std::optional<std::pair<EpisodeFigures, EpisodeFigures>> whole_clip;
  std::string checkpoint;
  int64_t policy_version = -1, samples = -1;
};

// The file's text (JSON, two-space indents, keys sorted), without a final newline.
std::string ComposeEvaluationJson(const EvaluationSections& sections);

// Writes `json` as RUN/eval.json, whole or not at all (a temporary file renamed). Throws
// std::runtime_error naming the file when it cannot be written.
void WriteEvaluationFile(const std::string& run_dir, const std::string& json);

// An eval.json as read back (what `ragdoll report` shows). The checkpoint fields are -1 / empty
// when the file predates them.
struct EvaluationSummary {
  int episodes = 0;
  double mean_return = 0, normalized_return = 0, episode_length = 0, fall_rate = 0;
  // Each reward term's mean by name (the imitation terms, and a task's), in the order the table
  // shows them: the imitation terms first, as the environment lists them.
  std::vector<std::pair<std::string, double>> reward_terms;
  int64_t policy_version = -1, samples = -1;
  std::string checkpoint;
  double survived_90 = -1;  // with push trials: largest impulse survived in 90 %, N s
  bool pushes = false;
  // DeepMimic's protocol (eval --pushes): per direction of the heading, the largest impulse
  // survived in 90 % (N s) and the whole body's change of velocity (m/s); empty without it.
  struct DirectionPush {
    std::string direction;
    double impulse = 0, velocity_change = 0;
    bool at_limit = false;
  };
  std::vector<DirectionPush> push_directions;
  // eval --recovery: the share of settled falls standing (held `recovery_hold` s) within 5 s and
  // 10 s and the median time, s (-1: never); recovery_trials 0 without it.
  int recovery_trials = 0;
  double recovery_hold = 0, within_5 = 0, within_10 = 0, recovery_median = -1;
  // eval --commands with knock-downs: how many, the share back on command within `back_window`
  // s and the median time, s (-1: never); knockdowns 0 without any.
  int knockdowns = 0;
  double back_window = 0, back_within = 0, back_median = -1;
};

// Throws ConfigError naming `origin` for text that is not JSON or lacks the evaluation's fields.
EvaluationSummary ParseEvaluationJson(const std::string& text, const std::string& origin);

}  // namespace ragdoll::eval
