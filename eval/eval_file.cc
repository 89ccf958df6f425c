#include "eval/eval_file.h"

#include <algorithm>
#include <filesystem>
#include <iterator>
#include <nlohmann/json.hpp>

#include "common/config_section.h"
#include "common/whole_file.h"
#include "sim/imitation_reward.h"

namespace ragdoll::eval {
namespace {

using sim::kImitationTerms;

nlohmann::json EpisodeJson(const EpisodeFigures& e) {
  return {{"normalized_return", e.normalized_return},
          {"episode_length", e.episode_length},
          {"fell", e.fell}};
}

}  // namespace

std::string ComposeEvaluationJson(const EvaluationSections& s) {
  nlohmann::json result = nlohmann::json::parse(s.episodes);
  if (!s.push_protocol.empty()) {
    result["perturbation"]["protocol"] = nlohmann::json::parse(s.push_protocol);
  }
  if (!s.recovery.empty()) result["recovery"] = nlohmann::json::parse(s.recovery);
  if (!s.commands.empty()) {
    result["commands"] = nlohmann::json::parse(s.commands);
    result["commands"]["script"] = s.command_script;
  }
  if (s.whole_clip) {
    result["whole_clip"] = EpisodeJson(s.whole_clip->first);
    result["whole_clip"]["reference_tracking"] = EpisodeJson(s.whole_clip->second);
  }
  // Which checkpoint was evaluated goes with the figures (`ragdoll report` shows it).
  result["checkpoint"] = s.checkpoint;
  result["policy_version"] = s.policy_version;
  result["samples"] = s.samples;
  return result.dump(2);
}

void WriteEvaluationFile(const std::string& run_dir, const std::string& json) {
  WriteWholeFile((std::filesystem::path(run_dir) / kEvaluationFile).string(), json + "\n");
}

EvaluationSummary ParseEvaluationJson(const std::string& text, const std::string& origin) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(origin + ": not JSON (" + e.what() + ")");
  }
  EvaluationSummary s;
  try {
    s.episodes = j.at("episodes").get<int>();
    s.mean_return = j.at("mean_return").get<double>();
    s.normalized_return = j.at("normalized_return").get<double>();
    s.episode_length = j.at("episode_length").get<double>();
    s.fall_rate = j.at("fall_rate").get<double>();
    // The imitation terms first, in the environment's order; a task's after them.
    std::vector<std::pair<std::string, double>> imitation, others;
    for (const auto& [name, value] : j.at("reward_terms").items()) {
      const auto known = std::find(std::begin(kImitationTerms), std::end(kImitationTerms), name);
      (known != std::end(kImitationTerms) ? imitation : others)
          .emplace_back(name, value.get<double>());
    }
    std::sort(imitation.begin(), imitation.end(), [](const auto& a, const auto& b) {
      return std::find(std::begin(kImitationTerms), std::end(kImitationTerms), a.first) <
             std::find(std::begin(kImitationTerms), std::end(kImitationTerms), b.first);
    });
    s.reward_terms = std::move(imitation);
    s.reward_terms.insert(s.reward_terms.end(), others.begin(), others.end());
    s.policy_version = j.value("policy_version", int64_t{-1});
    s.samples = j.value("samples", int64_t{-1});
    s.checkpoint = j.value("checkpoint", std::string());
    if (j.contains("perturbation")) {
      s.pushes = true;
      const nlohmann::json& perturbation = j.at("perturbation");
      s.survived_90 = perturbation.value("survived_90", -1.0);
      if (perturbation.contains("protocol")) {
        for (const auto& d : perturbation.at("protocol").at("directions")) {
          s.push_directions.push_back(
              {d.at("direction").get<std::string>(), d.at("survived_90").get<double>(),
               d.at("velocity_change").get<double>(), d.value("at_limit", false)});
        }
      }
    }
    if (j.contains("recovery")) {
      const nlohmann::json& r = j.at("recovery");
      s.recovery_trials = r.at("trials").get<int>();
      s.recovery_hold = r.value("hold", 0.5);
      s.within_5 = r.at("within_5").get<double>();
      s.within_10 = r.at("within_10").get<double>();
      s.recovery_median = r.at("median_seconds").get<double>();
    }
    if (j.contains("commands") && j.at("commands").contains("knockdowns")) {
      const nlohmann::json& k = j.at("commands").at("knockdowns");
      s.knockdowns = k.at("count").get<int>();
      s.back_window = k.at("back_window").get<double>();
      s.back_within = k.at("share_back_within").get<double>();
      s.back_median = k.at("median_seconds").is_null() ? -1 : k.at("median_seconds").get<double>();
    }
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(origin + ": not an evaluation written by `ragdoll eval` (" + e.what() + ")");
  }
  return s;
}

}  // namespace ragdoll::eval
