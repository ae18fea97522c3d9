#pragma once
// Evaluating the reference matcher on a dataset view (issue 4). Scoring: scoring/scoring.hpp.

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"
#include "matcher/matcher.hpp"
#include "measure/measure.hpp"
#include "scoring/scoring.hpp"
#include "params/parameter_space.hpp"
#include "store/observation_store.hpp"

namespace maptune::evaluation {

inline constexpr const char* kMatcherId = "lru_matcher";
// Counts code changes that alter the matcher's results: the part of a matcher version before
// its '-'. A worker runs tasks carrying settings for any version of its own revision.
inline constexpr const char* kMatcherCodeRevision = "4";

// "<revision>-<fingerprint of every non-optimized setting>": part of the observation key, so
// different settings (or code) never share an observation.
std::string matcher_version(const matcher::MatcherSettings& settings);

// Submap by id ("run00/submap003"); nullptr with `error` set when it cannot be had.
using SubmapSource = std::function<const dataset::Submap*(const std::string& id, std::string* error)>;

// The one path from a parameter set to per-pair results (Evaluator and the worker backend):
// runs `matcher` on the pairs "idA|idB" (each submap fetched once) with the full rounded set
// and returns one record per pair id, in order. nullopt with `error` naming the pair id or
// submap when a pair id is malformed or a submap cannot be had.
std::optional<std::vector<store::PairRecord>> match_pair_ids(matcher::Matcher& matcher,
                                                             const params::ParameterSet& params,
                                                             const std::vector<std::string>& pair_ids,
                                                             const SubmapSource& submaps, std::string* error,
                                                             matcher::EvaluationStats* stats = nullptr);

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
    // storing the result unless a pair timed out (store::has_timeouts). `from_store` tells
    // which happened. Before the first evaluation for a store it verifies the dataset's content
    // id and throws (naming the directory) when the files changed.
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
    bool verified_ = false;  // the dataset's files match its content id (checked before storing)
};

store::PairStatus to_store_status(matcher::MatchStatus status);

}  // namespace maptune::evaluation
