// The pure part of `ragdoll report`: a run's files, given as text, read into structs, and the
// page built from them as strings (SVG curves, self-contained HTML). No file, process or clock
// access here; cli/report_command.cc does that, so the tests call these functions directly.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ragdoll::cli {

// A run's metrics.csv (written by the learner, one row per PPO update), columns by header name
// so that columns added later, or missing optional ones, do not matter.
struct MetricsTable {
  std::vector<std::string> columns;         // the header, in file order
  std::vector<std::vector<double>> values;  // values[column][row]
  size_t rows = 0;
  std::string note;  // what was tolerated (a last line cut short while the learner wrote it)

  // The column called `name`, or nullptr when the file does not have one.
  const std::vector<double>* Column(const std::string& name) const;
};

// Parses metrics.csv; `origin` names the file in messages. Throws ConfigError
// "origin:LINE: ..." for a missing header, a row whose number of cells differs from the header's,
// or a cell that is not a number (naming its column), and "origin: ..." when the columns the
// curves are drawn against (samples, elapsed_s) are absent. A last line without its newline and
// with too few cells is the learner caught mid-write: it is dropped and noted, not an error.
MetricsTable ParseMetricsCsv(const std::string& text, const std::string& origin);

// `ragdoll eval RUN` as written to <run>/eval.json. The checkpoint fields are -1 / empty when the
// file predates them.
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

// What the page shows of one run.
struct RunReport {
  std::string id;           // the folder's name (its path when two runs share a name)
  std::string path;         // as given on the command line, for the commands the page suggests
  std::string config_text;  // config.yaml ("" when the folder has none)
  MetricsTable metrics;
  std::optional<EvaluationSummary> evaluation;
  std::string gif;          // an animated GIF's bytes; empty when there is none
  std::string gif_caption;  // under the GIF, or why there is none
};

// The clip a run follows: the file stem of environment.motion in config.yaml, or for a steering
// run "steering: " and its motion set's names ("" if neither is there).
std::string ClipOfConfig(const std::string& config_yaml);

// Whether config.yaml trains a steerable character (has environment.steering).
bool SteersInConfig(const std::string& config_yaml);

// Keys (dotted paths) whose values differ between the runs' config.yaml, with each run's value
// ("" where a run lacks the key). Paths of clip files compare by value, so the same clip under
// two checkouts counts as different; lists compare as their flow-style text.
struct ConfigDifference {
  std::string key;
  std::vector<std::string> values;  // one per run
};
std::vector<ConfigDifference> CompareConfigs(const std::vector<std::string>& config_yamls);

// Wall time of each row, seconds: elapsed_s made cumulative across learner sessions (a resumed
// run starts its clock at zero again; its rows continue from the previous session's last time).
std::vector<double> CumulativeWallTime(const std::vector<double>& elapsed_s);

// The run colours, in order; runs beyond the palette reuse it.
const std::string& RunColour(size_t run);

// All curves in one SVG: normalised return, fall rate, episode length and each reward term
// (rows) against samples and against wall time (columns), every run overlaid in its colour,
// with a legend. Episode curves skip rows without finished episodes (episodes == 0) and
// non-finite cells; a run whose samples go back (a restart from an older checkpoint) starts a
// new line there. Polylines carry data-run, data-metric and data-axis attributes.
std::string CurvesSvg(const std::vector<RunReport>& runs);

// The whole page: a header per run, the curves, the evaluation table (or how to make one), the
// GIFs as data URIs, and a small script (legend toggles, hover readout). Loads nothing from
// the network. `generated` is a line for the footer (e.g. the time and the command).
std::string ReportHtml(const std::vector<RunReport>& runs, const std::string& curves_svg,
                       const std::string& generated);

// Base64 (RFC 4648, with padding), for data URIs.
std::string Base64(const std::string& bytes);

}  // namespace ragdoll::cli
