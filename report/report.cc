#include "report/report.h"

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <set>

#include "common/config_section.h"
#include "report/report_assets.h"

namespace ragdoll::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// 1 234 567, as the README writes figures.
std::string Count(int64_t n) {
  std::string digits = std::to_string(n < 0 ? -n : n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ' ';
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

// H:MM:SS, as the progress line writes elapsed time.
std::string Clock(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "—";
  const long s = std::lround(seconds);
  char text[32];
  std::snprintf(text, sizeof(text), "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  return text;
}

// --- the curves ---------------------------------------------------------------------------------

struct CurveSpec {
  std::string column;
  std::string title;
  std::string y_label;
  double y_max;  // a bounded quantity's fixed top; NaN: from the data
  bool always;   // plotted even when no run has a non-zero value (a task's figures are not)
};

// Every quantity is an episode statistic: rows without finished episodes have none. The figures
// the report has titles for; any other figure column gets a plain one (FigureCurves).
const CurveSpec kCurves[] = {
    {"normalized_return", "normalised return (1 = reference followed for the whole episode)",
     "normalised return", 1.0, true},
    {"fall_rate", "fall rate (episodes ended by a fall)", "fraction of episodes", 1.0, true},
    {"episode_length", "episode length", "control steps", kNaN, true},
    {"rotation", "reward term: rotation (joint rotations)", "per-step mean, 0-1", 1.0, true},
    {"velocity", "reward term: velocity (joint velocities)", "per-step mean, 0-1", 1.0, true},
    {"end_effector", "reward term: end_effector (hands and feet)", "per-step mean, 0-1", 1.0, true},
    {"com", "reward term: com (centre of mass)", "per-step mean, 0-1", 1.0, true},
    {"root", "reward term: root (root pose and velocity)", "per-step mean, 0-1", 1.0, true},
    {"task", "steering task term (velocity and heading tracking, weighted)", "per-step mean", kNaN,
     false},
    {"speed_error", "steering: speed error |v - v*|", "m/s", kNaN, false},
    {"heading_error", "steering: heading error", "rad", kNaN, false},
};

// The curves to consider: kCurves, then a curve for every other episode figure of some run (the
// learner writes its figures after its own last column, update_kl).
std::vector<CurveSpec> FigureCurves(const std::vector<RunReport>& runs) {
  std::vector<CurveSpec> curves(std::begin(kCurves), std::end(kCurves));
  for (const auto& run : runs) {
    const auto& columns = run.metrics.columns;
    auto figure = std::find(columns.begin(), columns.end(), "update_kl");
    if (figure == columns.end()) continue;
    for (++figure; figure != columns.end(); ++figure) {
      const std::string& name = *figure;
      if (std::none_of(curves.begin(), curves.end(),
                       [&](const CurveSpec& c) { return c.column == name; })) {
        curves.push_back({name, "episode figure: " + name, "per-step mean", kNaN, false});
      }
    }
  }
  return curves;
}

// Whether a curve has anything to show: a task's figures only for runs with that task.
bool Shown(const CurveSpec& spec, const std::vector<RunReport>& runs) {
  if (spec.always) return true;
  for (const auto& run : runs) {
    if (const auto* y = run.metrics.Column(spec.column)) {
      for (double v : *y) {
        if (std::isfinite(v) && v != 0) return true;
      }
    }
  }
  return false;
}

// The SVG's layout, px. Each plot sits in a cell; two cells a row (samples, wall time).
constexpr double kSvgWidth = 1200;
constexpr double kCellWidth = 600, kCellHeight = 250;
constexpr double kPlotLeft = 70, kPlotRight = 576, kPlotTop = 34, kPlotBottom = 200;
constexpr double kLegendRow = 24, kLegendTop = 10, kHeadingRow = 30;
constexpr int kMarkersUpTo = 40;  // few points: draw each one, so a short run still shows

struct Axis {
  double top = 1, step = 0.2;
};

// Axis from 0 to the lowest round top: steps of 1, 2 or 5 times a power of ten, at most 7.
Axis RoundAxis(double max) {
  if (!std::isfinite(max) || max <= 0) return {};
  const double magnitude = std::pow(10.0, std::floor(std::log10(max)) - 1);
  for (double step : {magnitude, 2 * magnitude, 5 * magnitude, 10 * magnitude, 20 * magnitude}) {
    const double intervals = std::ceil(max / step - 1e-9);
    if (intervals <= 7) return {intervals * step, step};
  }
  return {max, max};  // not reached: 20 magnitudes span at least max
}

// A tick's label with as many decimals as the step needs.
std::string TickLabel(double value, double step) {
  if (value == 0) return "0";
  int decimals = 0;
  while (decimals < 6) {
    const double scaled = step * std::pow(10.0, decimals);
    if (std::fabs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, scaled)) break;
    ++decimals;
  }
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

// How an x axis is shown: values divided by `scale`, ticks suffixed, the axis titled.
struct XAxisUnit {
  std::string axis;  // "samples" or "wall_time" (the column of the plot)
  double scale = 1;
  std::string suffix, label, unit;
};

XAxisUnit SamplesUnit(double max) {
  if (max >= 1e6) return {"samples", 1e6, "M", "samples", "samples"};
  if (max >= 1e4) return {"samples", 1e3, "k", "samples", "samples"};
  return {"samples", 1, "", "samples", "samples"};
}

XAxisUnit WallTimeUnit(double max_seconds) {
  if (max_seconds <= 300) return {"wall_time", 1, "", "wall time (s)", "s"};
  if (max_seconds <= 5 * 3600) return {"wall_time", 60, "", "wall time (min)", "min"};
  return {"wall_time", 3600, "", "wall time (h)", "h"};
}

// One run's points for one quantity, split where x goes back (a restart from an older
// checkpoint) so that the line does not run backwards across the plot.
std::vector<std::vector<std::pair<double, double>>> Segments(const std::vector<double>& x,
                                                             const std::vector<double>& y,
                                                             const std::vector<double>* episodes) {
  std::vector<std::vector<std::pair<double, double>>> segments(1);
  double last_x = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < x.size() && i < y.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    if (episodes && !((*episodes)[i] > 0)) continue;
    if (x[i] < last_x && !segments.back().empty()) segments.emplace_back();
    segments.back().emplace_back(x[i], y[i]);
    last_x = x[i];
  }
  if (segments.back().empty()) segments.pop_back();
  return segments;
}

struct RunCurves {
  std::vector<double> samples, wall_time;
  const std::vector<double>* episodes = nullptr;
};

RunCurves CurvesOf(const RunReport& run) {
  RunCurves c;
  if (const auto* s = run.metrics.Column("samples")) c.samples = *s;
  if (const auto* e = run.metrics.Column("elapsed_s")) c.wall_time = CumulativeWallTime(*e);
  c.episodes = run.metrics.Column("episodes");
  return c;
}

double MaxFinite(const std::vector<double>& v) {
  double m = 0;
  for (double x : v)
    if (std::isfinite(x)) m = std::max(m, x);
  return m;
}

// The y axis: the quantity's bound, or the data's largest value.
Axis PlotYAxis(const CurveSpec& spec, const XAxisUnit& unit, const std::vector<RunReport>& runs,
               const std::vector<RunCurves>& curves) {
  double y_data_max = 0;
  for (size_t r = 0; r < runs.size(); ++r) {
    if (const auto* y = runs[r].metrics.Column(spec.column)) {
      for (const auto& segment :
           Segments(unit.axis == "samples" ? curves[r].samples : curves[r].wall_time, *y,
                    curves[r].episodes)) {
        for (const auto& p : segment) y_data_max = std::max(y_data_max, p.second);
      }
    }
  }
  return std::isfinite(spec.y_max) && y_data_max <= spec.y_max ? Axis{spec.y_max, spec.y_max / 5}
                                                               : RoundAxis(y_data_max);
}

// A plot's axes and where their values land in its frame, px.
struct PlotScale {
  Axis x_axis, y_axis;
  double X(double x) const { return kPlotLeft + x / x_axis.top * (kPlotRight - kPlotLeft); }
  double Y(double y) const { return kPlotBottom - y / y_axis.top * (kPlotBottom - kPlotTop); }
};

// The plot's <g> with the data its hover readout needs, and its title.
void PlotOpening(std::string& svg, double ox, double oy, const CurveSpec& spec,
                 const XAxisUnit& unit, const PlotScale& scale) {
  // The hover readout gives samples in full and wall time in the axis' unit.
  const double readout_max =
      unit.axis == "samples" ? scale.x_axis.top * unit.scale : scale.x_axis.top;

  svg += "<g class=\"panel\" transform=\"translate(" + Format("%g", ox) + "," + Format("%g", oy) +
         ")\" data-metric=\"" + spec.column + "\" data-axis=\"" + unit.axis + "\" data-title=\"" +
         Escape(spec.title) + "\" data-x-unit=\"" + unit.unit + "\" data-x-max=\"" +
         Format("%.10g", readout_max) + "\" data-y-max=\"" + Format("%.10g", scale.y_axis.top) +
         "\" data-left=\"" + Format("%g", kPlotLeft) + "\" data-right=\"" +
         Format("%g", kPlotRight) + "\" data-top=\"" + Format("%g", kPlotTop) +
         "\" data-bottom=\"" + Format("%g", kPlotBottom) + "\">\n";
  svg += "<text x=\"" + Format("%g", kPlotLeft) + "\" y=\"20\" font-size=\"13\" fill=\"#222\">" +
         Escape(spec.title) + "</text>\n";
}

// Grid and ticks.
void PlotGrid(std::string& svg, const XAxisUnit& unit, const PlotScale& scale) {
  const Axis& x_axis = scale.x_axis;
  const Axis& y_axis = scale.y_axis;
  for (int i = 0; i * y_axis.step <= y_axis.top * (1 + 1e-9); ++i) {
    const double v = i * y_axis.step, y = scale.Y(v);
    svg += "<line x1=\"" + Format("%g", kPlotLeft) + "\" x2=\"" + Format("%g", kPlotRight) +
           "\" y1=\"" + Format("%.1f", y) + "\" y2=\"" + Format("%.1f", y) +
           "\" stroke=\"#e4e4e4\"/>" + "<text x=\"" + Format("%g", kPlotLeft - 6) + "\" y=\"" +
           Format("%.1f", y + 4) + "\" font-size=\"11\" fill=\"#444\" text-anchor=\"end\">" +
           TickLabel(v, y_axis.step) + "</text>\n";
  }
  for (int i = 0; i * x_axis.step <= x_axis.top * (1 + 1e-9); ++i) {
    const double v = i * x_axis.step, x = scale.X(v);
    svg += "<line x1=\"" + Format("%.1f", x) + "\" x2=\"" + Format("%.1f", x) + "\" y1=\"" +
           Format("%g", kPlotTop) + "\" y2=\"" + Format("%g", kPlotBottom) +
           "\" stroke=\"#e4e4e4\"/>" + "<text x=\"" + Format("%.1f", x) + "\" y=\"" +
           Format("%g", kPlotBottom + 16) +
           "\" font-size=\"11\" fill=\"#444\" text-anchor=\"middle\">" + TickLabel(v, x_axis.step) +
           (v > 0 ? unit.suffix : "") + "</text>\n";
  }
}

// The frame over the grid, and the axis titles.
void PlotFrame(std::string& svg, const CurveSpec& spec, const XAxisUnit& unit) {
  svg += "<rect class=\"frame\" x=\"" + Format("%g", kPlotLeft) + "\" y=\"" +
         Format("%g", kPlotTop) + "\" width=\"" + Format("%g", kPlotRight - kPlotLeft) +
         "\" height=\"" + Format("%g", kPlotBottom - kPlotTop) +
         "\" fill=\"#ffffff\" fill-opacity=\"0\" stroke=\"#999\"/>\n";
  svg += "<text x=\"" + Format("%g", (kPlotLeft + kPlotRight) / 2) + "\" y=\"" +
         Format("%g", kPlotBottom + 36) +
         "\" font-size=\"12\" fill=\"#333\" text-anchor=\"middle\">" + unit.label + "</text>\n";
  const double mid = (kPlotTop + kPlotBottom) / 2;
  svg += "<text x=\"18\" y=\"" + Format("%g", mid) +
         "\" font-size=\"12\" fill=\"#333\" text-anchor=\"middle\" transform=\"rotate(-90 18 " +
         Format("%g", mid) + ")\">" + spec.y_label + "</text>\n";
}

// One run's line: a polyline per segment, with a marker per point when there are few.
void PlotRunLine(std::string& svg,
                 const std::vector<std::vector<std::pair<double, double>>>& segments,
                 const std::string& attributes, const std::string& colour, const XAxisUnit& unit,
                 const PlotScale& scale) {
  size_t points = 0;
  for (const auto& s : segments) points += s.size();
  for (const auto& segment : segments) {
    std::string coordinates;
    for (const auto& p : segment) {
      if (!coordinates.empty()) coordinates += ' ';
      coordinates +=
          Format("%.1f", scale.X(p.first / unit.scale)) + "," + Format("%.1f", scale.Y(p.second));
    }
    svg += "<polyline" + attributes + " fill=\"none\" stroke=\"" + colour +
           "\" stroke-width=\"1.8\" stroke-linejoin=\"round\" points=\"" + coordinates + "\"/>\n";
    if (points <= kMarkersUpTo || segment.size() == 1) {
      for (const auto& p : segment) {
        svg += "<circle class=\"marker\"" + attributes + " cx=\"" +
               Format("%.1f", scale.X(p.first / unit.scale)) + "\" cy=\"" +
               Format("%.1f", scale.Y(p.second)) + "\" r=\"2.2\" fill=\"" + colour + "\"/>\n";
      }
    }
  }
}

// The runs, in order: a later run is drawn over an earlier one. Returns why runs drew nothing.
std::vector<std::string> PlotRuns(std::string& svg, const CurveSpec& spec, const XAxisUnit& unit,
                                  const PlotScale& scale, const std::vector<RunReport>& runs,
                                  const std::vector<RunCurves>& curves) {
  std::vector<std::string> missing;
  for (size_t r = 0; r < runs.size(); ++r) {
    const auto* y = runs[r].metrics.Column(spec.column);
    const auto& x = unit.axis == "samples" ? curves[r].samples : curves[r].wall_time;
    auto segments = y ? Segments(x, *y, curves[r].episodes)
                      : std::vector<std::vector<std::pair<double, double>>>{};
    if (segments.empty()) {
      missing.push_back(runs[r].id + (y ? ": no finished episodes yet" : ": not in metrics.csv"));
      continue;
    }
    const std::string attributes = " data-run=\"" + std::to_string(r) + "\" data-metric=\"" +
                                   spec.column + "\" data-axis=\"" + unit.axis + "\"";
    PlotRunLine(svg, segments, attributes, RunColour(r), unit, scale);
  }
  return missing;
}

// One plot: frame, grid, ticks, titles and every run's lines, as a <g> placed at (ox, oy).
void Plot(std::string& svg, double ox, double oy, const CurveSpec& spec, const XAxisUnit& unit,
          const Axis& x_axis, const std::vector<RunReport>& runs,
          const std::vector<RunCurves>& curves) {
  const PlotScale scale{x_axis, PlotYAxis(spec, unit, runs, curves)};
  PlotOpening(svg, ox, oy, spec, unit, scale);
  PlotGrid(svg, unit, scale);
  PlotFrame(svg, spec, unit);
  const std::vector<std::string> missing = PlotRuns(svg, spec, unit, scale, runs, curves);
  for (size_t i = 0; i < missing.size(); ++i) {
    svg += "<text x=\"" + Format("%g", kPlotRight - 6) + "\" y=\"" +
           Format("%g", kPlotTop + 14 + 13 * static_cast<double>(i)) +
           "\" font-size=\"11\" fill=\"#777\" text-anchor=\"end\">" + Escape(missing[i]) +
           "</text>\n";
  }
  svg += "</g>\n";
}

// Flattens a YAML mapping into dotted keys and scalar (or flow-style list) values.
void Flatten(const YAML::Node& node, const std::string& prefix,
             std::map<std::string, std::string>* out) {
  if (node.IsMap()) {
    for (const auto& item : node) {
      const std::string key = item.first.as<std::string>();
      Flatten(item.second, prefix.empty() ? key : prefix + "." + key, out);
    }
  } else if (node.IsScalar()) {
    (*out)[prefix] = node.as<std::string>();
  } else if (node.IsSequence()) {
    YAML::Emitter e;
    e << YAML::Flow << node;
    (*out)[prefix] = e.c_str();
  } else {
    (*out)[prefix] = "";
  }
}

// The newest row with finished episodes, or -1.
long LastEpisodeRow(const learner::MetricsTable& m) {
  const auto* norm = m.Column("normalized_return");
  const auto* episodes = m.Column("episodes");
  if (!norm) return -1;
  for (long i = static_cast<long>(m.rows) - 1; i >= 0; --i) {
    if (std::isfinite((*norm)[i]) && (!episodes || (*episodes)[i] > 0)) return i;
  }
  return -1;
}

double LastValue(const learner::MetricsTable& m, const std::string& column) {
  const auto* c = m.Column(column);
  return c && m.rows > 0 ? c->back() : kNaN;
}

}  // namespace

std::string ClipOfConfig(const std::string& config_yaml) {
  try {
    YAML::Node root = YAML::Load(config_yaml);
    YAML::Node motion = root["environment"]["motion"];
    if (motion && motion.IsScalar()) {
      return std::filesystem::path(motion.as<std::string>()).stem().string();
    }
    YAML::Node motions = root["environment"]["steering"]["motions"];
    if (motions && motions.IsSequence()) {
      std::string names;
      for (const auto& m : motions) {
        std::string name;
        if (m["name"] && m["name"].IsScalar()) {
          name = m["name"].as<std::string>();
        } else if (m["motion"] && m["motion"].IsScalar()) {
          name = std::filesystem::path(m["motion"].as<std::string>()).stem().string();
        }
        if (!name.empty()) names += (names.empty() ? "" : ", ") + name;
      }
      return "steering: " + names;
    }
  } catch (const YAML::Exception&) {
  }
  return "";
}

bool SteersInConfig(const std::string& config_yaml) {
  try {
    YAML::Node steering = YAML::Load(config_yaml)["environment"]["steering"];
    return steering && steering.IsMap();
  } catch (const YAML::Exception&) {
    return false;
  }
}

std::vector<ConfigDifference> CompareConfigs(const std::vector<std::string>& config_yamls) {
  std::vector<std::map<std::string, std::string>> flat(config_yamls.size());
  std::set<std::string> keys;
  for (size_t r = 0; r < config_yamls.size(); ++r) {
    try {
      Flatten(YAML::Load(config_yamls[r]), "", &flat[r]);
    } catch (const YAML::Exception&) {
    }
    for (const auto& kv : flat[r]) keys.insert(kv.first);
  }
  std::vector<ConfigDifference> out;
  if (config_yamls.size() < 2) return out;
  for (const auto& key : keys) {
    ConfigDifference d{key, {}};
    for (const auto& f : flat) {
      auto it = f.find(key);
      d.values.push_back(it == f.end() ? "" : it->second);
    }
    if (std::adjacent_find(d.values.begin(), d.values.end(), std::not_equal_to<>()) !=
        d.values.end()) {
      out.push_back(d);
    }
  }
  return out;
}

std::vector<double> CumulativeWallTime(const std::vector<double>& elapsed_s) {
  std::vector<double> out;
  out.reserve(elapsed_s.size());
  double offset = 0, previous = kNaN;
  for (double e : elapsed_s) {
    if (!std::isfinite(e)) {
      out.push_back(kNaN);
      continue;
    }
    if (std::isfinite(previous) && e < previous) offset += previous;
    out.push_back(e + offset);
    previous = e;
  }
  return out;
}

const std::string& RunColour(size_t run) {
  // Tableau 10, with red second: the usual A/B pair reads as blue against red.
  static const std::vector<std::string> palette = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                   "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                                   "#bcbd22", "#17becf"};
  return palette[run % palette.size()];
}

std::string CurvesSvg(const std::vector<RunReport>& runs) {
  std::vector<RunCurves> curves;
  double max_samples = 0, max_seconds = 0;
  for (const auto& run : runs) {
    curves.push_back(CurvesOf(run));
    max_samples = std::max(max_samples, MaxFinite(curves.back().samples));
    max_seconds = std::max(max_seconds, MaxFinite(curves.back().wall_time));
  }
  const XAxisUnit samples_unit = SamplesUnit(max_samples);
  const XAxisUnit time_unit = WallTimeUnit(max_seconds);
  const Axis samples_axis = RoundAxis(max_samples / samples_unit.scale);
  const Axis time_axis = RoundAxis(max_seconds / time_unit.scale);

  // The legend: runs left to right, wrapping; its height moves the plots down.
  std::string legend;
  double lx = 70, ly = kLegendTop + 14;
  for (size_t r = 0; r < runs.size(); ++r) {
    const double width = 46 + 7.2 * static_cast<double>(runs[r].id.size());
    if (lx + width > kSvgWidth - 20 && r > 0) {
      lx = 70;
      ly += kLegendRow;
    }
    legend += "<g class=\"legend-item\" data-run=\"" + std::to_string(r) +
              "\" transform=\"translate(" + Format("%g", lx) + "," + Format("%g", ly) +
              ")\"><line x1=\"0\" x2=\"26\" y1=\"-4\" y2=\"-4\" stroke=\"" + RunColour(r) +
              "\" stroke-width=\"4\"/><text x=\"32\" y=\"0\" font-size=\"13\" fill=\"#222\">" +
              Escape(runs[r].id) + "</text></g>\n";
    lx += width;
  }
  const double headings_top = ly + 14;
  const double plots_top = headings_top + kHeadingRow;
  const std::vector<CurveSpec> figure_curves = FigureCurves(runs);
  std::vector<const CurveSpec*> shown;
  for (const CurveSpec& spec : figure_curves) {
    if (Shown(spec, runs)) shown.push_back(&spec);
  }
  const double height = plots_top + kCellHeight * static_cast<double>(shown.size());

  std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Format("%g", kSvgWidth) +
                    "\" height=\"" + Format("%g", height) + "\" viewBox=\"0 0 " +
                    Format("%g", kSvgWidth) + " " + Format("%g", height) +
                    "\" font-family=\"DejaVu Sans, sans-serif\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  svg += legend;
  svg += "<text x=\"" + Format("%g", kPlotLeft) + "\" y=\"" + Format("%g", headings_top + 18) +
         "\" font-size=\"15\" font-weight=\"bold\" fill=\"#222\">against samples</text>\n";
  svg += "<text x=\"" + Format("%g", kCellWidth + kPlotLeft) + "\" y=\"" +
         Format("%g", headings_top + 18) +
         "\" font-size=\"15\" font-weight=\"bold\" fill=\"#222\">against wall time "
         "(learner sessions added up)</text>\n";
  for (size_t i = 0; i < shown.size(); ++i) {
    const double oy = plots_top + kCellHeight * static_cast<double>(i);
    Plot(svg, 0, oy, *shown[i], samples_unit, samples_axis, runs, curves);
    Plot(svg, kCellWidth, oy, *shown[i], time_unit, time_axis, runs, curves);
  }
  svg += "</svg>\n";
  return svg;
}

namespace {

// One row per run: its clip, samples, wall time, updates and latest returns, then notes.
std::string RunsTable(const std::vector<RunReport>& runs) {
  std::string h;
  h += "<table class=\"runs\">\n<tr><th></th><th>run</th><th>clip</th><th>samples</th>"
       "<th>wall time</th><th>PPO updates</th><th>latest normalised return</th>"
       "<th>evaluated normalised return</th></tr>\n";
  std::vector<std::string> notes;
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunReport& run = runs[r];
    const learner::MetricsTable& m = run.metrics;
    const std::string clip = ClipOfConfig(run.config_text);
    const double samples = LastValue(m, "samples");
    std::vector<double> wall;
    if (const auto* e = m.Column("elapsed_s")) wall = CumulativeWallTime(*e);
    const long last = LastEpisodeRow(m);
    h += "<tr><td><span class=\"swatch\" style=\"background:" + RunColour(r) + "\"></span></td>";
    h += "<td>" + Escape(run.id) + "</td>";
    h += "<td>" + (clip.empty() ? std::string("— (no config.yaml)") : Escape(clip)) + "</td>";
    h += "<td class=\"num\">" +
         (std::isfinite(samples) ? Count(static_cast<int64_t>(samples)) : "—") + "</td>";
    h += "<td class=\"num\">" + Clock(wall.empty() ? kNaN : wall.back()) + "</td>";
    h += "<td class=\"num\">" + std::to_string(m.rows) + "</td>";
    h += "<td class=\"num\">" +
         (last >= 0 ? Format("%.3f", (*m.Column("normalized_return"))[last]) : "—") + "</td>";
    h += "<td class=\"num\">" +
         (run.evaluation ? Format("%.3f", run.evaluation->normalized_return) : "—") +
         "</td></tr>\n";
    if (!m.note.empty()) notes.push_back(m.note);
    if (m.rows == 0) notes.push_back(run.id + ": metrics.csv has no rows yet");
  }
  h += "</table>\n";
  for (const auto& n : notes) h += "<p class=\"note\">" + Escape(n) + "</p>\n";
  return h;
}

// The training curves (CurvesSvg), with how to read them.
std::string CurvesSection(const std::string& curves_svg) {
  std::string h;
  h += "<h2>Training curves</h2>\n<p class=\"hint\">One point per PPO update: the mean over the "
       "episodes that finished since the previous update. Click a run in the legend to hide or "
       "show it; hover a plot to read its values.</p>\n";
  h += "<div id=\"curves\">\n" + curves_svg + "</div>\n";
  return h;
}

// Every evaluated run's names (`names` of its evaluation), in the order they first appear.
template <typename Names>
std::vector<std::string> NamesOfRuns(const std::vector<RunReport>& runs,
                                     const std::vector<size_t>& evaluated, Names names) {
  std::vector<std::string> all;
  for (size_t r : evaluated) {
    for (const std::string& name : names(*runs[r].evaluation)) {
      if (std::find(all.begin(), all.end(), name) == all.end()) all.push_back(name);
    }
  }
  return all;
}

// A table row: the quantity's name, then its value for each evaluated run.
struct EvaluationRow {
  std::string& h;
  const std::vector<RunReport>& runs;
  const std::vector<size_t>& evaluated;

  template <typename Value>
  void operator()(const std::string& name, Value value) const {
    h += "<tr><td>" + name + "</td>";
    for (size_t r : evaluated) h += "<td class=\"num\">" + value(*runs[r].evaluation) + "</td>";
    h += "</tr>\n";
  }
};

// The episodes' figures: return, falls, length, and each reward term.
void EpisodeRows(const EvaluationRow& row) {
  using E = const eval::EvaluationSummary&;
  row("normalised return", [](E e) { return Format("%.3f", e.normalized_return); });
  row("fall rate", [](E e) { return Format("%.2f", e.fall_rate); });
  row("episode length (steps)", [](E e) { return Format("%.1f", e.episode_length); });
  row("episodes", [](E e) { return std::to_string(e.episodes); });
  row("mean return", [](E e) { return Format("%.2f", e.mean_return); });
  const auto terms = NamesOfRuns(row.runs, row.evaluated, [](E e) {
    std::vector<std::string> names;
    for (const auto& term : e.reward_terms) names.push_back(term.first);
    return names;
  });
  for (const std::string& term : terms) {
    row(Escape(term) + " term", [&term](E e) {
      for (const auto& [name, value] : e.reward_terms) {
        if (name == term) return Format("%.3f", value);
      }
      return std::string("—");
    });
  }
}

// The pushes survived, when some run was pushed, and per direction of DeepMimic's protocol.
void PushRows(const EvaluationRow& row) {
  using E = const eval::EvaluationSummary&;
  const auto& runs = row.runs;
  const auto& evaluated = row.evaluated;
  if (std::any_of(evaluated.begin(), evaluated.end(),
                  [&](size_t r) { return runs[r].evaluation->pushes; })) {
    row("largest push survived in 90 % (N s)", [](E e) {
      return !e.pushes           ? std::string("—")
             : e.survived_90 < 0 ? std::string("none")
                                 : Format("%g", e.survived_90);
    });
  }
  const auto directions = NamesOfRuns(runs, evaluated, [](E e) {  // DeepMimic's protocol
    std::vector<std::string> names;
    for (const auto& d : e.push_directions) names.push_back(d.direction);
    return names;
  });
  for (const std::string& direction : directions) {
    row("push survived " + Escape(direction) + ", 0.2 s (N s, m/s)", [&direction](E e) {
      for (const auto& d : e.push_directions) {
        if (d.direction == direction) {
          return std::string(d.at_limit ? "&ge; " : "") + Format("%g", d.impulse) + ", " +
                 Format("%.2f", d.velocity_change);
        }
      }
      return std::string("—");
    });
  }
}

// Getting up from falls and back on command after knock-downs, when some run was tested.
void RecoveryRows(const EvaluationRow& row) {
  using E = const eval::EvaluationSummary&;
  const auto& runs = row.runs;
  const auto& evaluated = row.evaluated;
  if (std::any_of(evaluated.begin(), evaluated.end(),
                  [&](size_t r) { return runs[r].evaluation->recovery_trials > 0; })) {
    row("standing within 5 s / 10 s of settled falls", [](E e) {
      return e.recovery_trials == 0 ? std::string("—")
                                    : Format("%.0f %%", 100 * e.within_5) + " / " +
                                          Format("%.0f %%", 100 * e.within_10) + " of " +
                                          std::to_string(e.recovery_trials) + ", held " +
                                          Format("%g", e.recovery_hold) + " s";
    });
    row("median time to stand (s)", [](E e) {
      return e.recovery_trials == 0  ? std::string("—")
             : e.recovery_median < 0 ? std::string("never")
                                     : Format("%.2f", e.recovery_median);
    });
  }
  if (std::any_of(evaluated.begin(), evaluated.end(),
                  [&](size_t r) { return runs[r].evaluation->knockdowns > 0; })) {
    row("knock-downs under command: back on command within the window", [](E e) {
      return e.knockdowns == 0
                 ? std::string("—")
                 : Format("%.0f %%", 100 * e.back_within) + " of " + std::to_string(e.knockdowns) +
                       " within " + Format("%g", e.back_window) + " s, median " +
                       (e.back_median < 0 ? std::string("never") : Format("%.2f s", e.back_median));
    });
  }
}

// Which checkpoint was evaluated.
void CheckpointRows(const EvaluationRow& row) {
  using E = const eval::EvaluationSummary&;
  row("policy version", [](E e) {
    return e.policy_version < 0 ? std::string("—") : "v" + std::to_string(e.policy_version);
  });
  row("samples of the checkpoint",
      [](E e) { return e.samples < 0 ? std::string("—") : Count(e.samples); });
  row("checkpoint", [](E e) {
    return e.checkpoint.empty() ? std::string("—")
                                : Escape(std::filesystem::path(e.checkpoint).filename().string());
  });
}

// The table of the evaluated runs, then a note for each whose training has gone on since.
std::string EvaluationTable(const std::vector<RunReport>& runs,
                            const std::vector<size_t>& evaluated) {
  std::string h;
  h += "<p class=\"hint\">Deterministic policy (mean action), episodes from random phases "
       "(<code>ragdoll eval</code>).</p>\n<table class=\"evaluation\">\n<tr><th></th>";
  for (size_t r : evaluated) {
    h += "<th><span class=\"swatch\" style=\"background:" + RunColour(r) + "\"></span> " +
         Escape(runs[r].id) + "</th>";
  }
  h += "</tr>\n";
  const EvaluationRow row{h, runs, evaluated};
  EpisodeRows(row);
  PushRows(row);
  RecoveryRows(row);
  CheckpointRows(row);
  h += "</table>\n";
  for (size_t r : evaluated) {
    const double now = LastValue(runs[r].metrics, "samples");
    const int64_t at = runs[r].evaluation->samples;
    if (at >= 0 && std::isfinite(now) && now > static_cast<double>(at)) {
      h += "<p class=\"note\">" + Escape(runs[r].id) + ": evaluated at " + Count(at) +
           " samples; training has reached " + Count(static_cast<int64_t>(now)) +
           " since (run <code>ragdoll eval " + Escape(runs[r].path) + "</code> again).</p>\n";
    }
  }
  return h;
}

// The latest evaluations: quantities as rows, runs with an eval.json as columns.
std::string EvaluationSection(const std::vector<RunReport>& runs) {
  std::string h;
  h += "<h2>Latest evaluation</h2>\n";
  std::vector<size_t> evaluated;
  for (size_t r = 0; r < runs.size(); ++r) {
    if (runs[r].evaluation) evaluated.push_back(r);
  }
  if (!evaluated.empty()) h += EvaluationTable(runs, evaluated);
  for (const auto& run : runs) {
    if (run.evaluation) continue;
    h += "<p class=\"note\">" + Escape(run.id) +
         ": no eval.json. Make one with <code>ragdoll eval " + Escape(run.path) +
         "</code> (it evaluates the newest checkpoint and writes " + Escape(run.path) +
         "/eval.json).</p>\n";
  }
  return h;
}

// Each run's newest policy beside its reference, as rendered (RunReport::gif).
std::string GifsSection(const std::vector<RunReport>& runs) {
  std::string h;
  h += "<h2>Newest policy beside its reference</h2>\n<div class=\"gifs\">\n";
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunReport& run = runs[r];
    h += "<figure>";
    if (!run.gif.empty()) {
      h += "<img alt=\"" + Escape(run.id) +
           ": the newest policy beside the reference ghost\" "
           "src=\"data:image/gif;base64," +
           Base64(run.gif) + "\">";
    }
    h += "<figcaption><span class=\"swatch\" style=\"background:" + RunColour(r) +
         "\"></span> <b>" + Escape(run.id) + "</b>: " + Escape(run.gif_caption) +
         "</figcaption></figure>\n";
  }
  h += "</div>\n";
  return h;
}

// The settings that differ between the runs, then each run's whole config.yaml.
std::string ConfigurationSection(const std::vector<RunReport>& runs) {
  std::string h;
  h += "<h2>Configuration</h2>\n";
  if (runs.size() > 1) {
    std::vector<std::string> texts;
    for (const auto& run : runs) texts.push_back(run.config_text);
    const auto differences = CompareConfigs(texts);
    if (differences.empty()) {
      h += "<p>The runs' config.yaml hold the same settings.</p>\n";
    } else {
      h += "<p>Settings that differ between the runs' config.yaml (—: not in that file, so the "
           "default applies):</p>\n<table>\n<tr><th>key</th>";
      for (size_t r = 0; r < runs.size(); ++r) h += "<th>" + Escape(runs[r].id) + "</th>";
      h += "</tr>\n";
      for (const auto& d : differences) {
        h += "<tr><td><code>" + Escape(d.key) + "</code></td>";
        for (const auto& v : d.values) {
          h += "<td class=\"wrap\">" + (v.empty() ? std::string("—") : Escape(v)) + "</td>";
        }
        h += "</tr>\n";
      }
      h += "</table>\n";
    }
  }
  for (const auto& run : runs) {
    h += "<details><summary>" + Escape(run.id) + "/config.yaml</summary><pre>" +
         (run.config_text.empty() ? std::string("(none)") : Escape(run.config_text)) +
         "</pre></details>\n";
  }
  return h;
}

}  // namespace

std::string ReportHtml(const std::vector<RunReport>& runs, const std::string& curves_svg,
                       const std::string& generated) {
  std::string ids;
  for (const auto& run : runs) ids += (ids.empty() ? "" : ", ") + run.id;
  std::string h = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h += "<title>ragdoll report: " + Escape(ids) + "</title>\n<style>" + kReportStyle + "</style>\n";
  h += "</head>\n<body>\n<h1>ragdoll report</h1>\n<p class=\"sub\">" + std::to_string(runs.size()) +
       (runs.size() == 1 ? " run" : " runs") + ": " + Escape(ids) + "</p>\n";

  h += RunsTable(runs);
  h += CurvesSection(curves_svg);
  h += EvaluationSection(runs);
  h += GifsSection(runs);
  h += ConfigurationSection(runs);
  h += "<footer><p>" + Escape(generated) + "</p></footer>\n<div id=\"readout\"></div>\n";
  h += std::string("<script>") + kReportScript + "</script>\n</body>\n</html>\n";
  return h;
}

std::string Base64(const std::string& bytes) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = static_cast<uint8_t>(bytes[i]) << 16 |
                       static_cast<uint8_t>(bytes[i + 1]) << 8 | static_cast<uint8_t>(bytes[i + 2]);
    out += alphabet[n >> 18 & 63];
    out += alphabet[n >> 12 & 63];
    out += alphabet[n >> 6 & 63];
    out += alphabet[n & 63];
  }
  if (i < bytes.size()) {
    uint32_t n = static_cast<uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<uint8_t>(bytes[i + 1]) << 8;
    out += alphabet[n >> 18 & 63];
    out += alphabet[n >> 12 & 63];
    out += i + 1 < bytes.size() ? alphabet[n >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace ragdoll::report
