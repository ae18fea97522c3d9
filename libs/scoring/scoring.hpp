#pragma once
// Scoring stored per-pair estimates against any reference of a dataset view (SPEC §5: errors
// and p are computed from the estimated transforms, so one observation serves gt and
// odometry, and any e*/m*). Light: no matcher, no PCL.

#include <optional>
#include <string>
#include <vector>

#include "dataset/dataset.hpp"
#include "measure/measure.hpp"
#include "store/observation_store.hpp"

namespace maptune::scoring {

// "run00/submap003|run00/submap004": the id of a pair's result in the store.
std::string pair_id(const dataset::SubmapPair& pair);
// The two submap ids of a pair id; none when it is not "<a>|<b>" with both non-empty.
std::optional<std::pair<std::string, std::string>> split_pair_id(const std::string& pair_id);

// Default m* (SPEC §2 asks for one derived from the data): the number of pairs of the view
// whose ground-truth overlap is at least `min_overlap` — the matches a good matcher can find.
// At least 1.
double derive_m_star(const std::vector<dataset::SubmapPair>& pairs, double min_overlap = 0.3);
// The same count over overlaps from the view's own reference (Dataset::reference_overlaps):
// with odometry as reference, m* never uses ground truth (`m_star: auto`, docs/datasets.md).
double derive_m_star(const std::vector<double>& overlaps, double min_overlap = 0.3);

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
    double mean_pair_s = 0;  // [s] mean PairRecord::duration_s over the pairs with a result
    std::vector<PairScore> per_pair;
};

// Scores per-pair results against the reference transforms of `pairs` (matched by pair id).
// d of each pair is the dataset's size of submap B.
ScoreReport score_observation(const dataset::Dataset& dataset,
                              const std::vector<dataset::SubmapPair>& pairs,
                              const std::vector<store::PairRecord>& results,
                              const measure::MeasureSettings& settings);

// One report over the union of several views' pairs (validation's "pooled" column): counts and
// per-pair scores concatenated, p recomputed from all matched pairs' errors with `settings`
// (its m* normally the sum of the views' m*), the mean pair time weighted by pairs timed.
// Pair ids of different views may repeat; they are kept as they are.
ScoreReport pool_reports(const std::vector<const ScoreReport*>& reports, const measure::MeasureSettings& settings);

}  // namespace maptune::scoring
