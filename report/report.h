// The pure part of `ragdoll report`: a run's files, given as text, read into structs, and the
// page built from them as strings (SVG curves, self-contained HTML). No file, process or clock
// access here; cli/report_command.cc does that, so the tests call these functions directly.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "eval/eval_file.h"
#include "learner/metrics_csv.h"

namespace ragdoll::report {

// What the page shows of one run.
struct RunReport {
  std::string id;           // the folder's name (its path when two runs share a name)
  std::string path;         // as given on the command line, for the commands the page suggests
  std::string config_text;  // config.yaml ("" when the folder has none)
  learner::MetricsTable metrics;
  std::optional<eval::EvaluationSummary> evaluation;
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

}  // namespace ragdoll::report
