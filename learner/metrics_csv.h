// metrics.csv, a run's training curves: one row per PPO update, written by the learner
// (training_log.h) and read by `ragdoll report`. The columns, the rows and the reader live here
// together, so that the writer and its reader cannot drift apart.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace ragdoll::learner {

// The file's name in a run folder.
inline constexpr char kMetricsFile[] = "metrics.csv";

// The columns of a new metrics.csv: the learner's own, then one per episode figure.
std::vector<std::string> MetricsColumns(const std::vector<std::string>& figure_names);
// The header line (without its newline): the column names, comma-separated.
std::string MetricsHeader(const std::vector<std::string>& columns);
// A metrics.csv row: `cells` (by column name) in `columns`' order, comma-separated. A column
// without a cell (a figure this run's environment does not report, in the file of a resumed older
// run) holds 0, as the learner wrote such figures before they had names.
std::string MetricsRow(const std::vector<std::string>& columns,
                       const std::map<std::string, std::string>& cells);
// The columns an existing metrics.csv at `path` names in its first line (empty: no file, or no
// header), so that a resumed run appends rows in its file's own order.
std::vector<std::string> ReadMetricsHeader(const std::string& path);

// A metrics.csv as read back, columns by header name so that columns added later, or missing
// optional ones, do not matter.
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

}  // namespace ragdoll::learner
