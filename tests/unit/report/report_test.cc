#include "report/report.h"

#include <gtest/gtest.h>

#include <regex>

#include "common/config_section.h"
#include "tests/unit/error_of.h"

namespace ragdoll::report {
namespace {

const std::string kHeader =
    "iteration,version,samples,elapsed_s,samples_per_s,episodes,mean_return,normalized_return,"
    "episode_length,fall_rate,rotation,velocity,end_effector,com,root,policy_loss,value_loss,"
    "entropy,approx_kl,clip_fraction,explained_variance,learning_rate,update_s,stale_dropped,"
    "rejected";

// A metrics.csv row in the learner's column order, with the given plotted values.
std::string Row(int iteration, double samples, double elapsed, int episodes, double normalized,
                double length = 30, double fall = 0.5) {
  char text[512];
  std::snprintf(text, sizeof(text),
                "%d,%d,%g,%g,1200,%d,20.5,%g,%g,%g,0.8,0.4,0.6,0.7,0.5,-0.01,0.2,1.4,0.01,0.1,"
                "0.5,0.003,1.2,0,0\n",
                iteration, iteration, samples, elapsed, episodes, normalized, length, fall);
  return text;
}

struct Polyline {
  int run;
  std::string metric, axis;
  std::vector<std::string> points;
};

std::vector<Polyline> Polylines(const std::string& svg) {
  std::vector<Polyline> out;
  const std::regex re(
      "<polyline data-run=\"(\\d+)\" data-metric=\"(\\w+)\" data-axis=\"(\\w+)\"[^>]* "
      "points=\"([^\"]*)\"/>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    Polyline p{std::stoi((*it)[1]), (*it)[2], (*it)[3], {}};
    std::string points = (*it)[4];
    for (size_t start = 0; start < points.size();) {
      size_t space = points.find(' ', start);
      p.points.push_back(points.substr(start, space - start));
      start = space == std::string::npos ? points.size() : space + 1;
    }
    out.push_back(p);
  }
  return out;
}

std::vector<Polyline> Select(const std::vector<Polyline>& all, int run, const std::string& metric,
                             const std::string& axis) {
  std::vector<Polyline> out;
  for (const auto& p : all) {
    if (p.run == run && p.metric == metric && p.axis == axis) out.push_back(p);
  }
  return out;
}

size_t Occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

RunReport RunOf(const std::string& id, const std::string& csv) {
  RunReport r;
  r.id = id;
  r.path = "runs/" + id;
  r.metrics = learner::ParseMetricsCsv(csv, r.path + "/metrics.csv");
  return r;
}

TEST(WallTime, AddsUpLearnerSessions) {
  // The resumed learner's clock starts again from zero.
  EXPECT_EQ(CumulativeWallTime({10, 20, 30, 5, 15}), (std::vector<double>{10, 20, 30, 35, 45}));
  EXPECT_EQ(CumulativeWallTime({}), std::vector<double>{});
}

TEST(CurvesSvg, PlacesEachPointOnTheAxes) {
  // Samples 0..4000 (axis 0..4000, step 1000), wall time 10..50 s (axis 0..50 s): the plot area is
  // x 70..576, y 200 (value 0) .. 34 (value 1). The row without finished episodes is left out.
  RunReport run = RunOf("a", kHeader + "\n" + Row(1, 0, 10, 4, 0) + Row(2, 1000, 20, 0, 0.9) +
                                 Row(3, 2000, 30, 4, 0.5) + Row(4, 3000, 40, 4, 0.75) +
                                 Row(5, 4000, 50, 4, 1.0));
  const std::string svg = CurvesSvg({run});
  const auto all = Polylines(svg);
  EXPECT_EQ(all.size(), 16u);  // 8 quantities against samples and against wall time
  auto by_samples = Select(all, 0, "normalized_return", "samples");
  ASSERT_EQ(by_samples.size(), 1u);
  EXPECT_EQ(by_samples[0].points,
            (std::vector<std::string>{"70.0,200.0", "323.0,117.0", "449.5,75.5", "576.0,34.0"}));
  auto by_time = Select(all, 0, "normalized_return", "wall_time");
  ASSERT_EQ(by_time.size(), 1u);
  EXPECT_EQ(by_time[0].points,
            (std::vector<std::string>{"171.2,200.0", "373.6,117.0", "474.8,75.5", "576.0,34.0"}));
  // Episode length 30 steps: an axis of 0..30 from the data, so every point on the top line.
  auto length = Select(all, 0, "episode_length", "samples");
  ASSERT_EQ(length.size(), 1u);
  EXPECT_EQ(length[0].points.size(), 4u);
  EXPECT_EQ(length[0].points[0], "70.0,34.0");
  // Tick labels with units.
  EXPECT_NE(svg.find(">4000</text>"), std::string::npos);
  EXPECT_NE(svg.find(">50</text>"), std::string::npos);
  EXPECT_NE(svg.find(">wall time (s)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">control steps</text>"), std::string::npos);
  // Few points: each one marked too (4 points x 16 plots).
  EXPECT_EQ(Occurrences(svg, "<circle class=\"marker\""), 64u);
}

TEST(CurvesSvg, StartsANewLineWhereAResumedRunsSamplesGoBack) {
  // Killed at 3000 samples, resumed from the checkpoint at 2000: samples go back, the clock
  // restarts.
  RunReport run =
      RunOf("resumed", kHeader + "\n" + Row(1, 1000, 10, 4, 0.1) + Row(2, 2000, 20, 4, 0.2) +
                           Row(3, 3000, 30, 4, 0.3) + Row(4, 2000, 5, 4, 0.2) +
                           Row(5, 3000, 15, 4, 0.3) + Row(6, 4000, 25, 4, 0.4));
  const auto all = Polylines(CurvesSvg({run}));
  auto by_samples = Select(all, 0, "fall_rate", "samples");
  ASSERT_EQ(by_samples.size(), 2u);
  EXPECT_EQ(by_samples[0].points.size(), 3u);
  EXPECT_EQ(by_samples[1].points.size(), 3u);
  EXPECT_EQ(by_samples[1].points[0], by_samples[0].points[1]);  // back at 2000 samples
  auto by_time = Select(all, 0, "fall_rate", "wall_time");
  ASSERT_EQ(by_time.size(), 1u);  // 10, 20, 30, 35, 45, 55 s
  EXPECT_EQ(by_time[0].points.size(), 6u);
}

TEST(CurvesSvg, OverlaysRunsInTheirColoursAndNotesMissingColumns) {
  RunReport a = RunOf("a", kHeader + "\n" + Row(1, 4096, 3, 4, 0.2) + Row(2, 8192, 6, 4, 0.4));
  // An older or newer learner without the reward terms, and with an extra column.
  RunReport b = RunOf("b",
                      "samples,elapsed_s,episodes,normalized_return,fall_rate,idle\n"
                      "4096,4,3,0.3,0.5,0.1\n8192,8,3,0.5,0.25,0.1\n12288,12,3,0.6,0,0.1\n");
  const std::string svg = CurvesSvg({a, b});
  const auto all = Polylines(svg);
  EXPECT_EQ(all.size(), 16u + 4u);  // b: return and fall rate, against samples and wall time
  ASSERT_EQ(Select(all, 1, "normalized_return", "samples").size(), 1u);
  EXPECT_EQ(Select(all, 1, "normalized_return", "samples")[0].points.size(), 3u);
  EXPECT_EQ(Select(all, 1, "rotation", "samples").size(), 0u);
  EXPECT_EQ(Occurrences(svg, "stroke=\"" + RunColour(0) + "\" stroke-width=\"1.8\""), 16u);
  EXPECT_EQ(Occurrences(svg, "stroke=\"" + RunColour(1) + "\" stroke-width=\"1.8\""), 4u);
  EXPECT_NE(RunColour(0), RunColour(1));
  EXPECT_EQ(Occurrences(svg, "class=\"legend-item\""), 2u);
  // b has no episode length nor reward terms: 6 quantities against samples and wall time.
  EXPECT_EQ(Occurrences(svg, ">b: not in metrics.csv</text>"), 12u);
  // Samples up to 12288: the axis reads in thousands, 0 to 14k in steps of 2k.
  EXPECT_NE(svg.find(">2k</text>"), std::string::npos);
  EXPECT_NE(svg.find(">14k</text>"), std::string::npos);
  EXPECT_EQ(svg.find(">16k</text>"), std::string::npos);
}

// The learner writes a task's figures after its own columns: one the report has no title for is
// plotted under its name.
TEST(CurvesSvg, PlotsAnEpisodeFigureItHasNoTitleFor) {
  RunReport a = RunOf("a",
                      "samples,elapsed_s,episodes,normalized_return,update_kl,root_height\n"
                      "4096,4,3,0.3,0.01,0.9\n8192,8,3,0.5,0.01,0.85\n");
  const std::string svg = CurvesSvg({a});
  EXPECT_EQ(Select(Polylines(svg), 0, "root_height", "samples").size(), 1u);
  EXPECT_NE(svg.find(">episode figure: root_height</text>"), std::string::npos);
}

TEST(Config, NamesASteeringRunsMotionSet) {
  const std::string steer =
      "environment:\n  steering:\n    motions:\n      - motion: /a/stand.json\n"
      "      - {motion: /a/strafe_left.json, mirror: true, name: strafe_right}\n"
      "      - {motion: /a/walk_start.json, from: stand, to: walk}\n";
  EXPECT_EQ(ClipOfConfig(steer), "steering: stand, strafe_right, walk_start");
  EXPECT_TRUE(SteersInConfig(steer));
}

TEST(Config, NamesTheClipAndTheSettingsThatDiffer) {
  const std::string a =
      "environment:\n  motion: /src/assets/motions/squat.json\n  max_episode_steps: 300\n"
      "trainer:\n  hyperparameters:\n    learning_rate: 0.0003\n    batch_size: 512\n";
  const std::string b =
      "environment:\n  motion: /src/assets/motions/squat.json\n  max_episode_steps: 300\n"
      "  allowed_contacts: [right_ankle, left_ankle]\n"
      "trainer:\n  hyperparameters:\n    learning_rate: 0.001\n    batch_size: 512\n";
  EXPECT_EQ(ClipOfConfig(a), "squat");
  EXPECT_EQ(ClipOfConfig("trainer: {}\n"), "");
  EXPECT_EQ(ClipOfConfig("not: [valid"), "");
  EXPECT_FALSE(SteersInConfig(a));
  EXPECT_FALSE(SteersInConfig("not: [valid"));
  auto d = CompareConfigs({a, b});
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].key, "environment.allowed_contacts");
  EXPECT_EQ(d[0].values, (std::vector<std::string>{"", "[right_ankle, left_ankle]"}));
  EXPECT_EQ(d[1].key, "trainer.hyperparameters.learning_rate");
  EXPECT_EQ(d[1].values, (std::vector<std::string>{"0.0003", "0.001"}));
  EXPECT_TRUE(CompareConfigs({a, a}).empty());
  EXPECT_TRUE(CompareConfigs({a}).empty());
}

TEST(Html, IsSelfContainedAndShowsEachRun) {
  RunReport a = RunOf("a", kHeader + "\n" + Row(1, 4096, 30, 4, 0.25) +
                               Row(2, 200000, 4000, 4, 0.5) + Row(3, 250000, 4100, 0, 0));
  a.config_text = "environment:\n  motion: /x/assets/motions/stand.json\n";
  a.evaluation = eval::ParseEvaluationJson(
      R"({"checkpoint": "runs/a/checkpoints/checkpoint-000000123456.pt", "episode_length": 29.5,
          "episodes": 20, "fall_rate": 0.05, "mean_return": 25.25, "normalized_return": 0.987,
          "policy_version": 12, "samples": 123456, "reward_terms": {"com": 0.9,
          "end_effector": 0.8, "root": 0.7, "rotation": 0.6, "velocity": 0.5},
          "perturbation": {"survived_90": 20, "protocol": {"directions": [{"direction":
          "forward", "survived_90": 38.75, "velocity_change": 0.6458, "at_limit": false}]}},
          "recovery": {"trials": 100, "seconds": 10, "hold": 0.5, "within_5": 0.91,
          "within_10": 0.99, "median_seconds": 1.9667, "times": [], "postures": []},
          "commands": {"runs": 20, "knockdowns": {"count": 80, "back_window": 6, "back_within": 72,
          "share_back_within": 0.9, "median_seconds": 4.8}}})",
      "eval.json");
  a.gif = std::string("GIF89a\x01\x00\x01\x00", 10);
  a.gif_caption = "5 s of the newest checkpoint";
  RunReport b = RunOf("<b>", "samples,elapsed_s\n4096,3\n");
  b.path = "runs/b";
  b.gif_caption = "not rendered (--no-gif)";
  const std::string html = ReportHtml({a, b}, CurvesSvg({a, b}), "generated for the test");

  // Nothing to fetch: the only URI is the SVG namespace, which is a name, not a load.
  std::string rest = html;
  const std::string ns = "xmlns=\"http://www.w3.org/2000/svg\"";
  EXPECT_EQ(Occurrences(rest, ns), 1u);
  rest.replace(rest.find(ns), ns.size(), "");
  EXPECT_EQ(rest.find("http://"), std::string::npos);
  EXPECT_EQ(rest.find("https://"), std::string::npos);
  EXPECT_EQ(rest.find("src=\"//"), std::string::npos);
  EXPECT_EQ(rest.find("url("), std::string::npos);
  EXPECT_EQ(rest.find("@import"), std::string::npos);

  // Header: clip, samples, wall time (4100 s), updates, latest return (the last row with
  // episodes), evaluation.
  EXPECT_NE(html.find("<td>stand</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">250 000</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">1:08:20</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">3</td><td class=\"num\">0.500</td>"
                      "<td class=\"num\">0.987</td>"),
            std::string::npos);
  // The evaluation table and its checkpoint, and how to refresh it.
  EXPECT_NE(html.find("<td>fall rate</td><td class=\"num\">0.05</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>push survived forward, 0.2 s (N s, m/s)</td><td class=\"num\">38.75, "
                      "0.65</td>"),
            std::string::npos);
  EXPECT_NE(html.find("<td>standing within 5 s / 10 s of settled falls</td><td class=\"num\">91 "
                      "% / 99 % of 100, held 0.5 s</td>"),
            std::string::npos)
      << html;
  EXPECT_NE(html.find("<td>knock-downs under command: back on command within the window</td>"
                      "<td class=\"num\">90 % of 80 within 6 s, median 4.80 s</td>"),
            std::string::npos)
      << html;
  EXPECT_NE(html.find("<td>median time to stand (s)</td><td class=\"num\">1.97</td>"),
            std::string::npos);
  EXPECT_NE(html.find("<td>policy version</td><td class=\"num\">v12</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">123 456</td>"), std::string::npos);
  EXPECT_NE(html.find("checkpoint-000000123456.pt"), std::string::npos);
  EXPECT_NE(html.find("training has reached 250 000 since"), std::string::npos);
  // The run without one says how to make it; its id is escaped everywhere.
  EXPECT_NE(html.find("&lt;b&gt;: no eval.json. Make one with <code>ragdoll eval runs/b</code>"),
            std::string::npos);
  EXPECT_EQ(html.find("<b>:"), std::string::npos);
  // The GIF as a data URI ("GIF89a" is "R0lGODlh" in base64), the other run's caption.
  EXPECT_NE(html.find("src=\"data:image/gif;base64,R0lGODlhAQABAA==\""), std::string::npos);
  EXPECT_EQ(Occurrences(html, "data:image/gif;base64,"), 1u);
  EXPECT_NE(html.find("not rendered (--no-gif)"), std::string::npos);
  // The curves inline, the script that toggles runs from the legend.
  EXPECT_EQ(Occurrences(html, "<svg "), 1u);
  EXPECT_NE(html.find("<script>"), std::string::npos);
  EXPECT_NE(html.find("item.addEventListener('click'"), std::string::npos);
  EXPECT_NE(html.find("console.log('ragdoll report: '"), std::string::npos);
  EXPECT_NE(html.find("generated for the test"), std::string::npos);
}

TEST(Base64, MatchesRfc4648) {
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("M"), "TQ==");
  EXPECT_EQ(Base64("Ma"), "TWE=");
  EXPECT_EQ(Base64("Man"), "TWFu");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64(std::string("\xff\xfe\x00", 3)), "//4A");
}

}  // namespace
}  // namespace ragdoll::report
