// metrics.csv's writer and reader together: what the learner writes reads back by column name.
#include "learner/metrics_csv.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "common/config_section.h"
#include "tests/unit/error_of.h"

namespace ragdoll::learner {
namespace {

TEST(MetricsCsv, ReadsColumnsByNameWithExtraColumnsAnywhere) {
  // A column the learner may add later (in the middle, to be sure order does not matter).
  const std::string text =
      "samples,actor_idle,elapsed_s,normalized_return,episodes\n"
      "4096,0.25,3.5,0.125,8\n"
      "8192,0.5,7,0.25,9\n"
      "12288,0.75,10.5,nan,0\n";
  MetricsTable m = ParseMetricsCsv(text, "m.csv");
  ASSERT_EQ(m.rows, 3u);
  EXPECT_EQ(m.columns.size(), 5u);
  EXPECT_EQ(*m.Column("samples"), (std::vector<double>{4096, 8192, 12288}));
  EXPECT_EQ(*m.Column("actor_idle"), (std::vector<double>{0.25, 0.5, 0.75}));
  EXPECT_DOUBLE_EQ((*m.Column("elapsed_s"))[2], 10.5);
  EXPECT_TRUE(std::isnan((*m.Column("normalized_return"))[2]));
  EXPECT_EQ(m.Column("fall_rate"), nullptr);
  EXPECT_TRUE(m.note.empty());
}

TEST(MetricsCsv, ReadsBackWhatTheLearnerWritesWithWindowsLineEndsToo) {
  const std::vector<std::string> columns = MetricsColumns({"rotation", "velocity"});
  std::string text = MetricsHeader(columns) + "\r\n" +
                     MetricsRow(columns, {{"samples", "4096"}, {"normalized_return", "0.2"}}) +
                     "\r\n" + MetricsRow(columns, {{"samples", "8192"}}) + "\n";
  MetricsTable m = ParseMetricsCsv(text, "m.csv");
  EXPECT_EQ(m.rows, 2u);
  EXPECT_EQ(m.columns, columns);
  EXPECT_EQ(m.columns.back(), "velocity");
  EXPECT_DOUBLE_EQ((*m.Column("normalized_return"))[0], 0.2);
  EXPECT_DOUBLE_EQ((*m.Column("rejected"))[1], 0);
  EXPECT_DOUBLE_EQ((*m.Column("samples"))[1], 8192);
}

TEST(MetricsCsv, RefusesMalformedFilesNamingFileLineAndColumn) {
  EXPECT_EQ(ConfigErrorOf([] { ParseMetricsCsv("", "runs/a/metrics.csv"); }),
            "runs/a/metrics.csv:1: no header: the first line must name the columns "
            "(iteration,version,samples,...)");
  EXPECT_EQ(ConfigErrorOf([] { ParseMetricsCsv("1,4096,3.5\n2,8192,7\n", "runs/a/metrics.csv"); }),
            "runs/a/metrics.csv:1: no header: the first line must name the columns "
            "(iteration,version,samples,...), found '1' in column 1");
  EXPECT_EQ(ConfigErrorOf([] {
              ParseMetricsCsv("samples,elapsed_s,fall_rate\n4096,3.5,0\n8192,7,abc\n", "m.csv");
            }),
            "m.csv:3: column 3 (fall_rate): 'abc' is not a number");
  EXPECT_EQ(
      ConfigErrorOf([] { ParseMetricsCsv("samples,elapsed_s,fall_rate\n4096,,0\n", "m.csv"); }),
      "m.csv:2: column 2 (elapsed_s): '' is not a number");
  EXPECT_EQ(ConfigErrorOf([] {
              ParseMetricsCsv("samples,elapsed_s,fall_rate\n4096,3.5\n8192,7,0\n", "m.csv");
            }),
            "m.csv:2: 2 cells, but the header names 3 columns");
  EXPECT_EQ(ConfigErrorOf([] { ParseMetricsCsv("iteration,elapsed_s\n1,3.5\n", "m.csv"); }),
            "m.csv: no 'samples' column (the curves are drawn against samples and elapsed_s)");
  EXPECT_EQ(ConfigErrorOf([] { ParseMetricsCsv("samples,elapsed_s,samples\n1,2,3\n", "m.csv"); }),
            "m.csv:1: column 'samples' appears twice in the header");
  // Without its newline the last line may be half written: dropped, unless it has too many cells.
  EXPECT_EQ(ConfigErrorOf([] { ParseMetricsCsv("samples,elapsed_s\n4096,3.5\n8192,x", "m.csv"); }),
            "");
  EXPECT_EQ(
      ConfigErrorOf([] { ParseMetricsCsv("samples,elapsed_s\n4096,3.5\n8192,7,1", "m.csv"); }),
      "m.csv:3: 3 cells, but the header names 2 columns");
}

TEST(MetricsCsv, DropsALastLineCaughtHalfWritten) {
  MetricsTable m = ParseMetricsCsv("samples,elapsed_s,fall_rate\n4096,3.5,0\n8192,7", "m.csv");
  EXPECT_EQ(m.rows, 1u);
  EXPECT_EQ(m.note, "m.csv:3: last line incomplete (being written?), left out");
  // The same line with its newline is a malformed file.
  EXPECT_EQ(
      ConfigErrorOf([] { ParseMetricsCsv("samples,elapsed_s,fall_rate\n8192,7\n", "m.csv"); }),
      "m.csv:2: 2 cells, but the header names 3 columns");
}

TEST(MetricsCsv, ResumedRunsAppendInTheirFilesOwnColumnOrder) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("metrics_csv_test_" + std::to_string(getpid()));
  // An older run's file: fewer columns, another order.
  std::ofstream(path) << "samples,iteration,elapsed_s\n4096,1,3.5\n";
  const std::vector<std::string> columns = ReadMetricsHeader(path.string());
  EXPECT_EQ(columns, (std::vector<std::string>{"samples", "iteration", "elapsed_s"}));
  std::ofstream(path, std::ios::app)
      << MetricsRow(
             columns,
             {{"iteration", "2"}, {"samples", "8192"}, {"elapsed_s", "7"}, {"fall_rate", "0.5"}})
      << "\n";
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const MetricsTable m = ParseMetricsCsv(text, path.string());
  EXPECT_EQ(*m.Column("samples"), (std::vector<double>{4096, 8192}));
  EXPECT_EQ(*m.Column("iteration"), (std::vector<double>{1, 2}));
  EXPECT_EQ(m.Column("fall_rate"), nullptr);
  EXPECT_TRUE(ReadMetricsHeader((path.string() + ".missing")).empty());
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace ragdoll::learner
