#include "cli/report_command.h"

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "common/config_section.h"
#include "common/process.h"
#include "common/run_config.h"
#include "common/whole_file.h"
#include "learner/checkpoint_store.h"
#include "report/report.h"

namespace ragdoll::cli {
namespace {
namespace fs = std::filesystem;

struct ReportOptions {
  std::vector<std::string> runs;
  std::string out, png;
  bool no_gif = false;
  double gif_seconds = 5;
  int gif_width = 320, gif_height = 180;
};

// Rendering a few seconds in software OpenGL takes seconds to a minute on a busy machine; the
// limit is there so that a hung Xvfb cannot hang the report.
constexpr double kRenderTimeoutSeconds = 180;
constexpr double kRasteriseTimeoutSeconds = 60;
// Above this a GIF makes the page slow to open; the user is told how to shorten it.
constexpr uintmax_t kLargeGifBytes = 1500 * 1000;
// The renderer's caption has a fixed font size: drawn at twice the GIF's size and scaled down,
// it covers a quarter of the frame instead of half. The tracking camera changes most pixels of
// every frame, so the size grows with the frame rate: 15 frames/s keeps 5 s near 1 MB.
constexpr int kRenderScale = 2;
constexpr int kGifFramesPerSecond = 15;

// The folder's name, or "main" for ".", "runs/x/" -> "x".
std::string RunName(const std::string& path) {
  fs::path p = fs::absolute(path).lexically_normal();
  if (!p.has_filename()) p = p.parent_path();
  return p.filename().string();
}

// Reads what the page shows of a run folder; throws ConfigError naming what is missing.
report::RunReport ReadRun(const std::string& path) {
  if (!fs::is_directory(path)) throw ConfigError("report: " + path + ": no such run folder");
  const fs::path csv = fs::path(path) / "metrics.csv";
  if (!fs::exists(csv)) {
    throw ConfigError("report: " + path +
                      ": no metrics.csv (not a run folder, or its learner has not finished a "
                      "PPO update yet)");
  }
  report::RunReport run;
  run.path = path;
  run.id = RunName(path);
  run.metrics = learner::ParseMetricsCsv(ReadWholeFile(csv.string()), csv.string());
  run.config_text = ReadRunConfig(path);
  const fs::path evaluation = fs::path(path) / eval::kEvaluationFile;
  if (fs::exists(evaluation)) {
    run.evaluation =
        eval::ParseEvaluationJson(ReadWholeFile(evaluation.string()), evaluation.string());
  }
  return run;
}

// Renders the run's newest policy into a GIF with this binary's `render` and returns its bytes;
// on failure returns nothing, says why in the caption and warns.
std::string RenderGif(const std::string& self, const ReportOptions& o, const fs::path& work,
                      size_t index, report::RunReport* run) {
  const std::string checkpoint = learner::FindCheckpoint(run->path);
  if (checkpoint.empty()) {
    run->gif_caption = "no checkpoint yet, so nothing to render";
    std::fprintf(stderr, "report: warning: %s has no checkpoint; no GIF\n", run->path.c_str());
    return "";
  }
  const std::string name = "run" + std::to_string(index);
  const fs::path full = work / (name + "-full.gif"), gif = work / (name + ".gif");
  const fs::path log = work / (name + ".log");
  char seconds[32];
  std::snprintf(seconds, sizeof(seconds), "%g", o.gif_seconds);
  std::vector<std::string> render = {self,
                                     "render",
                                     run->path,
                                     "--out",
                                     full.string(),
                                     "--seconds",
                                     seconds,
                                     "--width",
                                     std::to_string(o.gif_width * kRenderScale),
                                     "--height",
                                     std::to_string(o.gif_height * kRenderScale)};
  // A steering policy shown standing on its first command says little: it follows a random
  // command script instead, captioned frame by frame.
  const bool steering = report::SteersInConfig(run->config_text);
  if (steering) render.insert(render.end(), {"--commands", "random"});
  const std::string size = std::to_string(o.gif_width) + ":" + std::to_string(o.gif_height);
  const std::vector<std::string> shrink = {
      "ffmpeg",
      "-loglevel",
      "error",
      "-y",
      "-i",
      full.string(),
      "-vf",
      "fps=" + std::to_string(kGifFramesPerSecond) + ",scale=" + size +
          ":flags=lanczos,split[a][b];[a]palettegen=stats_mode=diff[p];[b][p]paletteuse",
      gif.string()};
  std::fprintf(stderr, "report: rendering %s (%s s, %dx%d)...\n", run->path.c_str(), seconds,
               o.gif_width, o.gif_height);
  int code = RunProcess(render, log, kRenderTimeoutSeconds);
  if (code == 0) code = RunProcess(shrink, log, kRenderTimeoutSeconds);
  std::error_code error;
  const uintmax_t bytes = fs::file_size(gif, error);
  if (code != 0 || error || bytes == 0) {
    const std::string why =
        code < 0
            ? "timed out after " + std::to_string(static_cast<int>(kRenderTimeoutSeconds)) + " s"
            : "exit code " + std::to_string(code) + ": " + LastLine(log);
    run->gif_caption = "rendering failed (" + why + "); try `ragdoll render " + run->path +
                       " --out clip.gif` to see why";
    std::fprintf(stderr, "report: warning: rendering %s failed (%s); the page has no GIF for it\n",
                 run->path.c_str(), why.c_str());
    return "";
  }
  if (bytes > kLargeGifBytes) {
    std::fprintf(stderr,
                 "report: warning: the GIF of %s is %.1f MB; --gif-seconds or --gif-width "
                 "smaller keep the page light\n",
                 run->path.c_str(), static_cast<double>(bytes) / 1e6);
  }
  run->gif_caption = std::string(seconds) + " s of the newest checkpoint (" +
                     fs::path(checkpoint).filename().string() + "), deterministic actions" +
                     (steering ? " following a random command script (the caption names "
                                 "the command)"
                               : "") +
                     "; the translucent figure beside it is the reference clip";
  return ReadWholeFile(gif.string());
}

// The curves as PNG: the same SVG rasterised by rsvg-convert (librsvg2-bin).
void WritePng(const std::string& svg, const fs::path& work, const std::string& png) {
  const fs::path svg_file = work / "curves.svg";
  WriteWholeFile(svg_file.string(), svg);
  const fs::path log = work / "rsvg-convert.log";
  const int code =
      RunProcess({"rsvg-convert", "--format", "png", "--output", png, svg_file.string()}, log,
                 kRasteriseTimeoutSeconds);
  if (code == 127) {
    throw std::runtime_error(
        "--png: cannot run rsvg-convert; install it (Debian package librsvg2-bin, in "
        "deploy/setup.sh)");
  }
  if (code != 0) {
    throw std::runtime_error("--png: rsvg-convert failed (exit code " + std::to_string(code) +
                             "): " + LastLine(log));
  }
  std::error_code error;
  if (fs::file_size(png, error) == 0 || error) {
    throw std::runtime_error("--png: rsvg-convert wrote no image to " + png);
  }
}

std::string Now() {
  std::time_t t = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S %Z", std::localtime(&t));
  return text;
}

int Report(const ReportOptions& o) {
  std::vector<report::RunReport> runs;
  for (const auto& path : o.runs) runs.push_back(ReadRun(path));
  // Two folders with one name (runs/a/x, other/x): the legend needs the paths to tell them apart.
  for (auto& run : runs) {
    int same = 0;
    for (const auto& other : runs) same += other.id == run.id;
    if (same > 1) run.id = run.path;
  }
  for (const auto& run : runs) {
    if (!run.metrics.note.empty()) std::fprintf(stderr, "report: %s\n", run.metrics.note.c_str());
  }

  char pattern[] = "/tmp/ragdoll-report.XXXXXX";
  const char* temporary = mkdtemp(pattern);
  if (!temporary) throw std::runtime_error("report: cannot make a temporary folder in /tmp");
  const fs::path work = temporary;
  struct RemoveWork {
    fs::path path;
    ~RemoveWork() {
      std::error_code ignored;
      fs::remove_all(path, ignored);
    }
  } remove_work{work};

  int gifs = 0;
  if (o.no_gif) {
    for (auto& run : runs) run.gif_caption = "not rendered (--no-gif)";
  } else {
    const std::string self = fs::read_symlink("/proc/self/exe").string();
    for (size_t i = 0; i < runs.size(); ++i) {
      runs[i].gif = RenderGif(self, o, work, i, &runs[i]);
      gifs += !runs[i].gif.empty();
    }
  }

  const std::string svg = report::CurvesSvg(runs);
  std::string paths;
  for (const auto& path : o.runs) paths += " " + path;
  const std::string html = report::ReportHtml(runs, svg, "ragdoll report" + paths + ", " + Now());
  WriteWholeFile(o.out, html);
  std::fprintf(stderr, "report: wrote %s (%.0f kB; %zu run%s, %d GIF%s)\n", o.out.c_str(),
               static_cast<double>(html.size()) / 1e3, runs.size(), runs.size() == 1 ? "" : "s",
               gifs, gifs == 1 ? "" : "s");
  if (!o.png.empty()) {
    WritePng(svg, work, o.png);
    std::fprintf(stderr, "report: wrote %s\n", o.png.c_str());
  }
  return 0;
}

}  // namespace

std::function<int()> AddReportCommand(CLI::App& app) {
  auto o = std::make_shared<ReportOptions>();
  auto* cmd = app.add_subcommand(
      "report", "one HTML page comparing runs: curves, latest evaluation, a GIF of each policy");
  cmd->add_option("runs", o->runs, "run folders (runs/<id>), overlaid in the order given")
      ->required();
  cmd->add_option("--out", o->out, "the HTML page to write")->required();
  cmd->add_option("--png", o->png, "also write the curves as a PNG (needs rsvg-convert)");
  cmd->add_flag("--no-gif", o->no_gif, "do not render a GIF of each run's newest policy");
  cmd->add_option("--gif-seconds", o->gif_seconds, "length of each GIF")
      ->capture_default_str()
      ->check(CLI::Range(0.5, 60.0));
  cmd->add_option("--gif-width", o->gif_width, "GIF width, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 1280));
  cmd->add_option("--gif-height", o->gif_height, "GIF height, px")
      ->capture_default_str()
      ->check(CLI::Range(64, 720));
  return [=]() -> int {
    if (!*cmd) return -1;
    return Report(*o);
  };
}

}  // namespace ragdoll::cli
