#pragma once
// Evaluating the reference matcher on a dataset view (issue 4) and scoring stored per-pair
// estimates against any reference (SPEC §5: errors and p are computed from the estimated
// transforms, so one observation serves gt and odometry, and any e*/m*).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"
#include "matcher/matcher.hpp"
#include "measure/measure.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"

namespace maptune::evaluation {

inline constexpr const char* kMatcherId = "lru_matcher";

// "run00/submap003|run00/submap004": the id of a pair's result in the store.
std::string pair_id(const dataset::SubmapPair& pair);

// Default m* (SPEC §2 asks for one derived from the data): the number of pairs of the view
// whose ground-truth overlap is at least `min_overlap` — the matches a good matcher can find.
// At least 1.
double derive_m_star(const std::vector<dataset::SubmapPair>& pairs, double min_overlap = 0.3);

struct ErrorStats {
    double mean = 0, median = 0, p90 = 0, max = 0;  // over matched pairs
};

struct PairScore {
    std::string pair_id;
    bool matched = false;
    store::PairStatus status = store::PairStatus::kOk;
    std::string reason;
    double overlap = 0;       // gt overlap of the pair
    double e_t = 0, e_r = 0;  // [m], [rad]; matched pairs only
    double d = 0;             // [m] size of submap B
    double rating = 0;        // r_i; matched pairs only
    double duration_s = 0;
};

struct ScoreReport {
    measure::MeasureSettings settings;
    measure::Score score;
    std::size_t pairs = 0, matched = 0, failed = 0, timeouts = 0;
    std::size_t missing = 0;  // pairs of the view without a result in the observation
    ErrorStats e_t, e_r;
    std::vector<PairScore> per_pair;
};

// Scores per-pair results against the reference transforms of `pairs` (matched by pair id).
// d of each pair is the dataset's size of submap B.
ScoreReport score_observation(const dataset::Dataset& dataset,
                              const std::vector<dataset::SubmapPair>& pairs,
                              const std::vector<store::PairRecord>& results,
                              const measure::MeasureSettings& settings);

// Fingerprint of every non-optimized matcher setting that changes results: part of the
// matcher version in observation keys, so different settings never share an observation.
std::string matcher_version(const matcher::MatcherSettings& settings);

// Runs the matcher over dataset views. Submaps are loaded on first use and kept.
class Evaluator {
public:
    Evaluator(const dataset::Dataset& dataset, const params::ParameterSpace& space,
              matcher::MatcherSettings settings = {}, matcher::FeatureCacheOptions cache = {});

    const dataset::Dataset& dataset() const { return dataset_; }
    const params::ParameterSpace& space() const { return space_; }
    matcher::Matcher& matcher() { return matcher_; }
    const std::string& matcher_version() const { return version_; }

    // The key of `params` (completed with defaults and rounded) on `view`.
    store::ObservationKey key(dataset::View view, const params::ParameterSet& params) const;

    // Runs the matcher on every pair of the view with the rounded full parameter set.
    // Never throws for bad parameter combinations: failures are per-pair statuses.
    store::Observation evaluate(dataset::View view, const params::ParameterSet& params,
                                matcher::EvaluationStats* stats = nullptr);

    // Looks the observation up in `db` (when given) and evaluates only when it is absent,
    // storing the result. `from_store` tells which happened.
    store::Observation evaluate_cached(store::ObservationStore* db, dataset::View view,
                                       const params::ParameterSet& params,
                                       bool* from_store = nullptr,
                                       matcher::EvaluationStats* stats = nullptr);

private:
    const dataset::Submap& submap(int run, int index);

    const dataset::Dataset& dataset_;
    params::ParameterSpace space_;
    matcher::Matcher matcher_;
    std::string version_;
    std::map<std::pair<int, int>, std::unique_ptr<dataset::Submap>> submaps_;
};

store::PairStatus to_store_status(matcher::MatchStatus status);

}  // namespace maptune::evaluation
