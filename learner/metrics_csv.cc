#include "learner/metrics_csv.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/config_section.h"

namespace ragdoll::learner {
namespace {

std::string JoinCells(const std::vector<std::string>& cells) {
  std::string line;
  for (const std::string& c : cells) line += (line.empty() ? "" : ",") + c;
  return line;
}

std::string Trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  size_t start = 0;
  while (true) {
    size_t comma = line.find(',', start);
    cells.push_back(Trim(line.substr(start, comma - start)));
    if (comma == std::string::npos) return cells;
    start = comma + 1;
  }
}

// A whole cell as a number; "nan" and "inf" (what iostreams write for them) included.
bool ParseNumber(const std::string& cell, double* value) {
  if (cell.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(cell.c_str(), &end);
  return end == cell.c_str() + cell.size();
}

}  // namespace

std::vector<std::string> MetricsColumns(const std::vector<std::string>& figure_names) {
  std::vector<std::string> columns = {
      "iteration",          "version",       "samples",           "elapsed_s",      "samples_per_s",
      "episodes",           "mean_return",   "normalized_return", "episode_length", "fall_rate",
      "policy_loss",        "value_loss",    "entropy",           "approx_kl",      "clip_fraction",
      "explained_variance", "learning_rate", "update_s",          "stale_dropped",  "rejected",
      "idle_fraction",      "update_kl"};
  columns.insert(columns.end(), figure_names.begin(), figure_names.end());
  return columns;
}

std::string MetricsHeader(const std::vector<std::string>& columns) { return JoinCells(columns); }

std::string MetricsRow(const std::vector<std::string>& columns,
                       const std::map<std::string, std::string>& cells) {
  std::vector<std::string> row;
  for (const std::string& c : columns) {
    auto it = cells.find(c);
    row.push_back(it == cells.end() ? "0" : it->second);
  }
  return JoinCells(row);
}

std::vector<std::string> ReadMetricsHeader(const std::string& path) {
  std::ifstream in(path);
  std::string line, cell;
  std::getline(in, line);
  std::vector<std::string> columns;
  std::istringstream cells(line);
  while (std::getline(cells, cell, ',')) columns.push_back(cell);
  return columns;
}

const std::vector<double>* MetricsTable::Column(const std::string& name) const {
  auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? nullptr : &values[it - columns.begin()];
}

MetricsTable ParseMetricsCsv(const std::string& text, const std::string& origin) {
  auto fail = [&](size_t line, const std::string& message) {
    throw ConfigError(origin + ":" + std::to_string(line) + ": " + message);
  };
  std::vector<std::string> lines;
  bool last_terminated = true;
  for (size_t start = 0; start < text.size();) {
    size_t newline = text.find('\n', start);
    if (newline == std::string::npos) {
      lines.push_back(text.substr(start));
      last_terminated = false;
      break;
    }
    lines.push_back(text.substr(start, newline - start));
    start = newline + 1;
  }
  if (lines.empty() || Trim(lines[0]).empty()) {
    fail(1, "no header: the first line must name the columns (iteration,version,samples,...)");
  }

  MetricsTable m;
  m.columns = SplitCells(lines[0]);
  for (size_t c = 0; c < m.columns.size(); ++c) {
    double number;
    if (m.columns[c].empty() || ParseNumber(m.columns[c], &number)) {
      fail(1,
           "no header: the first line must name the columns (iteration,version,samples,...), "
           "found '" +
               m.columns[c] + "' in column " + std::to_string(c + 1));
    }
    if (std::find(m.columns.begin(), m.columns.begin() + c, m.columns[c]) !=
        m.columns.begin() + c) {
      fail(1, "column '" + m.columns[c] + "' appears twice in the header");
    }
  }
  m.values.resize(m.columns.size());

  for (size_t i = 1; i < lines.size(); ++i) {
    const size_t line = i + 1;
    if (Trim(lines[i]).empty()) continue;
    // The learner appends a row at a time; a reader can catch the last one half written.
    const bool partial_allowed = i + 1 == lines.size() && !last_terminated;
    std::vector<std::string> cells = SplitCells(lines[i]);
    std::vector<double> row(cells.size());
    std::string problem;
    if (cells.size() != m.columns.size()) {
      problem = std::to_string(cells.size()) + " cells, but the header names " +
                std::to_string(m.columns.size()) + " columns";
    } else {
      for (size_t c = 0; c < cells.size() && problem.empty(); ++c) {
        if (!ParseNumber(cells[c], &row[c])) {
          problem = "column " + std::to_string(c + 1) + " (" + m.columns[c] + "): '" + cells[c] +
                    "' is not a number";
        }
      }
    }
    if (!problem.empty()) {
      if (partial_allowed && cells.size() <= m.columns.size()) {
        m.note = origin + ":" + std::to_string(line) +
                 ": last line incomplete (being written?), left out";
        break;
      }
      fail(line, problem);
    }
    for (size_t c = 0; c < cells.size(); ++c) m.values[c].push_back(row[c]);
    ++m.rows;
  }

  for (const char* required : {"samples", "elapsed_s"}) {
    if (!m.Column(required)) {
      throw ConfigError(origin + ": no '" + required +
                        "' column (the curves are drawn against samples and elapsed_s)");
    }
  }
  return m;
}

}  // namespace ragdoll::learner
