#pragma once
// Validating a tuning run on held-out dataset views (issue 11): the baseline (the experiment's
// start points), the best observed and the model's predicted best, each scored on every
// `validate:` target. Built on compare(): same m* rules, same observation store, so a set
// already scored on a view is never matched again.

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "evaluation/compare.hpp"
#include "experiment/experiment.hpp"

namespace maptune::evaluation {

// Generates the dataset from `generate` when `dir` holds no manifest yet; a no-op when it
// does. Throws params::ConfigError when there is neither a dataset nor a generate section.
void ensure_dataset(const std::string& dir, const std::optional<experiment::GenerateSpec>& generate,
                    const std::function<void(const std::string&)>& log);

// The matcher settings the experiment's workers use (they are part of every observation key).
matcher::MatcherSettings experiment_matcher_settings(const experiment::Experiment& e, int threads = 0);

// The experiment's `validate:` section as compare targets.
std::vector<CompareTarget> validation_targets(const experiment::Experiment& e);

// Row names of a validation.
inline constexpr const char* kBaselineSet = "baseline";
inline constexpr const char* kBestSet = "best";
inline constexpr const char* kPredictedSet = "predicted";
// Column of all held-out targets together (reserved as a target label).
inline constexpr const char* kPooledTarget = experiment::kPooledValidationLabel;

// Appends the column "pooled" when `r` has at least two columns of one view and reference:
// each set scored on the union of all columns' pairs, m* the sum of theirs (e* and w_v of the
// first column; a validation's columns share them). A single held-out view of a few hundred
// pairs, where a tuned set matches a few dozen, scores with a standard error of several
// hundredths; the union is the larger sample.
void add_pooled_column(CompareResult& r);

// The sets of a run directory: "baseline" (the first start point; further start points as
// "start:<file stem>"), "best" (best_params.yaml) and "predicted" (predicted_best.yaml, the
// GP's best posterior mean). Files that are absent are skipped; throws params::ConfigError
// when there is no best (a run without a successful evaluation) or a file is unreadable.
std::vector<NamedParameterSet> validation_sets(const experiment::Experiment& e,
                                               const std::filesystem::path& run_dir);

// Scores `sets` on every validation target (generating held-out datasets as needed) with the
// experiment's measure (e*, w_v) and matcher settings, plus the pooled column (above). Throws
// params::ConfigError when the experiment has no `validate:` section.
CompareResult validate(const experiment::Experiment& e, const std::vector<NamedParameterSet>& sets,
                       CompareOptions options);

// validation.csv: one line per (set, target) with p, m, eps, median errors and the
// difference of p to the baseline's on the same target (empty without a baseline row).
std::string validation_csv(const CompareResult& r);

// Repeats of one experiment (`seeds:`): the median and spread (max - min) over the seeds.
struct SeedOutcome {
    std::uint64_t seed = 0;
    std::filesystem::path run_dir;
    std::optional<double> best_p;                    // on the training view
    std::optional<CompareResult> validation;
};
struct Spread {
    double median = 0, min = 0, max = 0;
    int n = 0;
};
Spread spread(std::vector<double> values);

// The scores of a repeated run: columns "best_p" (training view), then "<set>@<target>" for
// every validation cell in first-seen order; per seed its values (absent: no such score);
// per column the spread over the seeds that have it.
struct SeedsSummary {
    std::vector<std::string> columns;
    std::vector<std::map<std::string, double>> rows;
    std::vector<Spread> spreads;
};
SeedsSummary summarize_seeds(const std::vector<SeedOutcome>& seeds);

// summary.csv of a repeated run: per seed the best training p and every validation p, then
// rows "median", "min", "max", "spread" over the seeds.
std::string seeds_summary_csv(const std::vector<SeedOutcome>& seeds);

}  // namespace maptune::evaluation
