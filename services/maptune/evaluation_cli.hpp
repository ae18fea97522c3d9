#pragma once
// Options and output shared by `maptune evaluate` and `maptune sweep`.
#ifdef MAPTUNE_HAVE_EVALUATION
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "evaluation/evaluation.hpp"

namespace maptune::cli {

struct EvaluationCliOptions {
    std::string dataset;
    std::string view = "complete";
    std::string reference = "gt";
    std::string space = "configs/spaces/lru_matcher.yaml";
    std::string params;                 // empty: the space's defaults
    std::optional<double> e_star, m_star;
    double w_v = 0.5;
    std::string db;                     // optional observation store
    int threads = 0;
    double pair_time_limit_s = 60, total_time_limit_s = 3600;
    std::vector<std::string> matcher_overrides;  // KEY=VALUE of matcher::MatcherSettings
};

void add_evaluation_options(CLI::App& cmd, EvaluationCliOptions& o);
// --threads, --pair-time-limit, --time-limit and --matcher KEY=VALUE (part of the above).
void add_matcher_options(CLI::App& cmd, EvaluationCliOptions& o);
// The measure settings: e* and m* given, or e* = 0.4 and m* derived from the view's overlaps
// under its own reference (odometry overlaps for --reference odometry: no ground truth).
measure::MeasureSettings measure_settings(const EvaluationCliOptions& o, const dataset::Dataset& ds,
                                          const std::vector<dataset::SubmapPair>& pairs);
// Throws params::ConfigError for a bad --matcher KEY=VALUE.
matcher::MatcherSettings matcher_settings(const EvaluationCliOptions& o);
nlohmann::json report_json(const scoring::ScoreReport& r, double wall_seconds, bool per_pair);

}  // namespace maptune::cli
#endif
